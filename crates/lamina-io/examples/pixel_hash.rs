//! Prints a hash of each image's decoded pixels (not of its file bytes), for comparing
//! renders before and after a change: `cargo run --release -p lamina-io --example
//! pixel_hash -- a.exr b.png ...` (used by scripts/render-hashes.sh).

fn main() {
    for path in std::env::args().skip(1) {
        match image::open(&path) {
            Ok(img) => {
                let pixels = img.to_rgba32f();
                // FNV-1a, 64-bit, over the f32 bit patterns: stable across builds.
                let mut h: u64 = 0xcbf2_9ce4_8422_2325;
                for v in pixels.as_raw() {
                    for b in v.to_bits().to_le_bytes() {
                        h ^= u64::from(b);
                        h = h.wrapping_mul(0x0000_0100_0000_01b3);
                    }
                }
                println!("{h:016x}  {}x{}  {path}", pixels.width(), pixels.height());
            }
            Err(e) => {
                eprintln!("error: {path}: {e}");
                std::process::exit(1);
            }
        }
    }
}
