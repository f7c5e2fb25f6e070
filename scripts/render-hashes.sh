#!/usr/bin/env bash
# Renders the example and gallery scenes, the demo and the GPU path at low sample counts and
# prints one SHA-256 per image: run it before and after a change that must not change
# behaviour (a refactor) and diff the two lists. The EXRs are the linear float film, so
# equal hashes mean bit-identical renders.
#   scripts/render-hashes.sh OUT_DIR > hashes.txt
#   SKIP_GPU=1 scripts/render-hashes.sh OUT_DIR    without the GPU path (no Vulkan)
set -euo pipefail
cd "$(dirname "$0")/.."
out=${1:?usage: scripts/render-hashes.sh OUT_DIR}
mkdir -p "$out"
cargo build --release -q -p lamina-cli
lamina=$PWD/target/release/lamina
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
(cd "$out" && sha256sum -- *.exr *.png)
