//! Image maps (PNG, JPEG, HDR, EXR by content): a texture in each encoding or an error, never
//! a panic or an allocation past the documented size cap.
#![no_main]
use lamina_leaf::texture::{Encoding, Texture};
use libfuzzer_sys::fuzz_target;

fuzz_target!(
    // The loaders turn a dependency's panic into an error; here it must crash instead.
    init: lamina_leaf::guard::propagate_panics(true),
    |data: &[u8]| {
    let name = std::path::Path::new("map.png");
    for enc in [Encoding::Srgb, Encoding::Linear] {
        if let Ok(t) = Texture::decode(data, enc, name) {
            let _ = t.sample(glam::Vec2::new(0.3, 0.7));
        }
    }
});
