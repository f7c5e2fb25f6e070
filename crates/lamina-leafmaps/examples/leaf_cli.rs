//! Stand-alone `lamina leaf` (the same code as `lamina-cli/src/leaf_cmd.rs`), to try and
//! compile-check the subcommands without the full CLI:
//! `cargo run --release -p lamina-leafmaps --example leaf_cli -- generate -s maple -o out/maple`

#[path = "../../lamina-cli/src/chart.rs"]
mod chart;
#[path = "../../lamina-cli/src/leaf_cmd.rs"]
mod leaf_cmd;
#[path = "../../lamina-cli/src/leaf_spectra_cmd.rs"]
mod leaf_spectra_cmd;
#[path = "../../lamina-cli/src/output_file.rs"]
mod output_file;

use clap::Parser;

/// Leaf map tools.
#[derive(Parser, Debug)]
struct Cli {
    #[command(subcommand)]
    command: leaf_cmd::LeafCommand,
}

fn main() -> std::process::ExitCode {
    match leaf_cmd::run(Cli::parse().command) {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            std::process::ExitCode::FAILURE
        }
    }
}
