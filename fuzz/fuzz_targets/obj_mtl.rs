//! The OBJ + MTL importer: the input is an OBJ, optionally followed by a line `#MTL` and the
//! text of `m.mtl` (which the OBJ can name with `mtllib m.mtl`). Both are written to a
//! scratch folder and loaded from there, as a scene would.
#![no_main]
use libfuzzer_sys::fuzz_target;
use std::sync::OnceLock;

static DIR: OnceLock<std::path::PathBuf> = OnceLock::new();

fuzz_target!(
    // The loaders turn a dependency's panic into an error; here it must crash instead.
    init: lamina_leaf::guard::propagate_panics(true),
    |data: &[u8]| {
    let dir = DIR.get_or_init(|| {
        let d = std::env::temp_dir().join(format!("lamina-fuzz-obj-{}", std::process::id()));
        std::fs::create_dir_all(&d).unwrap();
        d
    });
    let (obj, mtl) = match data.windows(5).position(|w| w == b"#MTL\n") {
        Some(i) => (&data[..i], &data[i + 5..]),
        None => (data, &b""[..]),
    };
    std::fs::write(dir.join("m.obj"), obj).unwrap();
    std::fs::write(dir.join("m.mtl"), mtl).unwrap();
    let _ = lamina_scene::obj::load_obj(&dir.join("m.obj"));
});
