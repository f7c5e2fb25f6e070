//! The glTF importer on arbitrary bytes (`.gltf` JSON or `.glb`): a scene or an error,
//! never a panic (the gltf crate's readers are only reached after our own checks).
#![no_main]
use libfuzzer_sys::fuzz_target;

fuzz_target!(
    // The loaders turn a dependency's panic into an error; here it must crash instead.
    init: lamina_leaf::guard::propagate_panics(true),
    |data: &[u8]| {
    let path = std::path::Path::new("/nonexistent-lamina-fuzz/model.gltf");
    let _ = lamina_scene::gltf_import::parse_gltf(data, path, &Default::default());
});
