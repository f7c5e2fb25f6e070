#!/usr/bin/env bash
# Regenerates the images shown in README.md (docs/images/). They are outputs of the
# renderer, committed only so that the README shows them; this script is the source.
set -euo pipefail
cd "$(dirname "$0")/.."
cargo build --release -p lamina-cli
target/release/lamina demo -o docs/images/demo.png --size 384 --spp 128 --quiet
# The leaf model's plots for crates/lamina-leaf/README.md (texel_patch.png stays out: too large).
out=$(mktemp -d)
cargo run --release -q -p lamina-leaf --example plot_model -- "$out"
mkdir -p docs/images/leaf-model
cp "$out/rt_vs_angle.png" "$out/rt_modes.png" docs/images/leaf-model/
rm -rf "$out"
