//! Leaf-card files, CSV and JSON: cards or an error naming the row, never a panic.
#![no_main]
use libfuzzer_sys::fuzz_target;

fuzz_target!(
    // The loaders turn a dependency's panic into an error; here it must crash instead.
    init: lamina_leaf::guard::propagate_panics(true),
    |data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let path = std::path::Path::new("cards.csv");
    let _ = lamina_scene::cards::parse_csv(path, text);
    let _ = lamina_scene::cards::parse_json(std::path::Path::new("cards.json"), text);
});
