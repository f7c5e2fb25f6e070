//! `leaf.toml`: a description (then its parameters validated) or an error, never a panic.
#![no_main]
use libfuzzer_sys::fuzz_target;

fuzz_target!(
    // The loaders turn a dependency's panic into an error; here it must crash instead.
    init: lamina_leaf::guard::propagate_panics(true),
    |data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let path = std::path::Path::new("leaf.toml");
    if let Ok(d) = lamina_leaf::LeafDescription::from_toml_str(text, path) {
        let _ = d.params.validate();
    }
});
