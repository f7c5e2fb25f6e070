//! Generates every species preset and writes a contact sheet of each to `out/leafmaps/`.
//!
//! `cargo run --release -p lamina-leafmaps --example gallery [RESOLUTION] [SEED]`

use lamina_leafmaps::sheet::{SheetOptions, sheet};
use lamina_leafmaps::{LeafSpec, Species, generate};
use std::path::PathBuf;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    let res = args.get(1).and_then(|s| s.parse().ok()).unwrap_or(1024);
    let seed = args.get(2).and_then(|s| s.parse().ok()).unwrap_or(1);
    let out = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../out/leafmaps");
    for s in Species::ALL {
        let leaf = generate(&LeafSpec::new(s, seed, res));
        let dir = out.join(format!("gen_{}", s.name()));
        leaf.write_folder(&dir)?;
        let png = out.join(format!("sheet_gen_{}.png", s.name()));
        sheet(&dir, &png, &SheetOptions::default())?;
        println!("{}", png.display());
    }
    Ok(())
}
