//! The `lamina plant generate` command, runnable on its own:
//! `cargo run --release -p lamina-plant --example generate -- --kind tree -n 100000 -o out/tree.glb`.

use clap::Parser;

#[path = "../../lamina-cli/src/output_file.rs"]
#[allow(dead_code)]
mod output_file;
#[path = "../../lamina-cli/src/plant_cmd.rs"]
mod plant_cmd;

/// Grow a procedural plant and write it as binary glTF.
#[derive(Parser, Debug)]
struct Cli {
    #[command(flatten)]
    args: plant_cmd::PlantGenerateArgs,
}

fn main() -> anyhow::Result<()> {
    plant_cmd::run_generate(Cli::parse().args)
}
