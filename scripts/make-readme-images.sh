#!/usr/bin/env bash
# Regenerates the images shown in README.md (docs/images/). They are outputs of the
# renderer, committed only so that the README shows them; this script is the source.
set -euo pipefail
cd "$(dirname "$0")/.."
cargo build --release -p lamina-cli
target/release/lamina demo -o docs/images/demo.png --size 384 --spp 128 --quiet
