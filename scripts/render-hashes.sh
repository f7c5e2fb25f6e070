#!/usr/bin/env bash
# Renders the example and gallery scenes, the demo and the GPU path at low sample counts and
# prints one hash of each image's decoded pixels (and the SHA-256 of each file): run it
# before and after a change that must not change behaviour (a refactor) and diff the two
# lists. The EXRs are the linear float film, so equal pixel hashes mean bit-identical
# renders.
#   scripts/render-hashes.sh OUT_DIR > hashes.txt
#   SKIP_GPU=1 scripts/render-hashes.sh OUT_DIR    without the GPU path (no Vulkan)
set -euo pipefail
cd "$(dirname "$0")/.."
out=${1:?usage: scripts/render-hashes.sh OUT_DIR}
mkdir -p "$out"
cargo build --release -q -p lamina-cli
cargo build --release -q -p lamina-io --example pixel_hash
lamina=${CARGO_TARGET_DIR:-$PWD/target}/release/lamina
flags=(--spp 4 --threads 2 --quiet --force)
for scene in examples/*.toml examples/gallery/*.toml; do
  name=$(basename "$scene" .toml)
  # Scenes are rendered at their own size; 4 spp keeps the whole set to a few minutes.
  "$lamina" render "$scene" -o "$out/$name.exr" -o "$out/$name.png" "${flags[@]}"
done
"$lamina" demo --size 96 -o "$out/demo.exr" -o "$out/demo.png" "${flags[@]}"
if [[ -z ${SKIP_GPU:-} ]]; then
  for scene in examples/plant.toml examples/gallery/fig5_bush_backlit.toml; do
    name=$(basename "$scene" .toml)
    "$lamina" render "$scene" --gpu -o "$out/gpu_$name.png" --quiet --force
  done
fi
pixel_hash=${CARGO_TARGET_DIR:-$PWD/target}/release/examples/pixel_hash
(cd "$out" && "$pixel_hash" *.exr *.png && sha256sum -- *.exr *.png)
