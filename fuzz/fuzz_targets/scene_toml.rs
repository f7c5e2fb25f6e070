//! The scene loader on arbitrary text: it must return a scene or an error, never panic.
//! Files the scene names resolve under a folder that does not exist. Scenes that grow
//! plants or generate species leaves are skipped (slow, not unsafe: `plant_params` covers
//! the plant parameters).
#![no_main]
use libfuzzer_sys::fuzz_target;

fuzz_target!(
    // The loaders turn a dependency's panic into an error; here it must crash instead.
    init: lamina_leaf::guard::propagate_panics(true),
    |data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    if text.contains("plant") || text.contains("species") {
        return;
    }
    let _ = lamina_scene::parse_scene(text, std::path::Path::new("/nonexistent-lamina-fuzz/s.toml"));
});
