//! Placement (instance) CSV files: transforms or an error naming the row, never a panic.
#![no_main]
use libfuzzer_sys::fuzz_target;

fuzz_target!(
    // The loaders turn a dependency's panic into an error; here it must crash instead.
    init: lamina_leaf::guard::propagate_panics(true),
    |data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let _ = lamina_scene::instances::parse_instances_csv(text, std::path::Path::new("p.csv"));
});
