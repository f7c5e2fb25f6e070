//! Plant parameter files: parameters (validated, then resolved to the numbers the grower
//! uses) or an error naming the key, never a panic. The plant is not grown (slow).
#![no_main]
use libfuzzer_sys::fuzz_target;

fuzz_target!(
    // The loaders turn a dependency's panic into an error; here it must crash instead.
    init: lamina_leaf::guard::propagate_panics(true),
    |data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    if let Ok(p) = lamina_plant::PlantParams::from_toml(text)
        && p.validate().is_ok()
    {
        let _ = p.resolve();
    }
});
