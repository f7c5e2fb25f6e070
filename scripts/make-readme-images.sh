#!/usr/bin/env bash
# Regenerates the images shown in README.md (docs/images/). They are outputs of the
# renderer, committed only so that the README shows them; this script is the source.
#   scripts/make-readme-images.sh            everything
#   scripts/make-readme-images.sh gallery    only the gallery (the paper's Fig. 4 and 5)
#   scripts/make-readme-images.sh rami       only the RAMI BRF plot
set -euo pipefail
cd "$(dirname "$0")/.."
cargo build --release -p lamina-cli
lamina=target/release/lamina
what=${1:-all}

if [[ $what == all ]]; then
  $lamina demo -o docs/images/demo.png --size 384 --spp 128 --quiet
  # The leaf model's plots for crates/lamina-leaf/README.md (texel_patch.png stays out: too large).
  out=$(mktemp -d)
  cargo run --release -q -p lamina-leaf --example plot_model -- "$out"
  mkdir -p docs/images/leaf-model
  cp "$out/rt_vs_angle.png" "$out/rt_modes.png" docs/images/leaf-model/
  rm -rf "$out"
  # Leaves from pigments under a sun placed by time (README, "Leaves from pigments and spectra").
  $lamina render examples/pigment_leaves.toml -o docs/images/pigment_leaves.png --quiet
  $lamina render examples/pigment_leaves_bands.toml -o docs/images/pigment_leaves_nir.png --quiet
  $lamina render examples/pigment_leaves.toml --set 'film.spectral="visible"' \
    -o docs/images/pigment_leaves_visible.png --quiet
  # The clear sky (Preetham, turbidity 2.5) at four sun elevations, for lamina-sky's README.
  out=$(mktemp -d)
  cargo run --release -q -p lamina-sky --example sky_images -- "$out"
  mkdir -p docs/images/sky
  for e in 60 30 10 03; do cp "$out/sky_e${e}_t2.5.png" docs/images/sky/; done
  rm -rf "$out"
  # The GPU path next to a converged offline render (GPU left), for the README's GPU section.
  cargo run --release -q -p lamina-gpu --example compare -- docs/images/gpu 192 1024
  # Lamps at night: the quad lamp's and the bulb's soft shadows, offline and on the GPU.
  $lamina render examples/lamps.toml --spp 256 -o docs/images/gpu/lamps-offline.png --quiet --force
  $lamina render --gpu examples/lamps.toml -o docs/images/gpu/lamps-gpu.png --force
fi

if [[ $what == all || $what == rami ]]; then
  # RAMI HOM11 in the NIR: lamina's BRF against Mitsuba 3's (README, "Measuring canopies").
  # Needs Mitsuba 3 and matplotlib (bench/README.md says how); without them, lamina's own plot.
  rami=$(mktemp -d)
  if python3 -c "import mitsuba, matplotlib" 2>/dev/null; then
    python3 bench/rami_compare.py --no-build --case HOM11 --bands nir --out "$rami"
    cp "$rami/HOM11_uni_nir.png" docs/images/rami_hom11_nir.png
  else
    $lamina canopy rami --case HOM11 --band nir -o "$rami/hom11" --force
    $lamina render "$rami/hom11/scene.toml" --quiet
    cp "$rami/hom11/brf.png" docs/images/rami_hom11_nir.png
  fi
  rm -rf "$rami"
  [[ $what == rami ]] && exit 0
fi

# The gallery: the paper's Fig. 4 (one plant from four sides under one sun) and Fig. 5 (a
# bush lit from behind), from the scene files in examples/gallery/.
gallery=docs/images/gallery
mkdir -p "$gallery"
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
for azimuth in 0 90 180 270; do
  # The same scene with the camera moved around the plant (distance 2.6 m, height 0.75 m).
  # The copy stays in examples/gallery so that relative paths in it still resolve.
  scene=examples/gallery/.fig4_$azimuth.toml
  python3 - "$azimuth" "$scene" <<'PY'
import math, sys
a = math.radians(float(sys.argv[1]))
text = open("examples/gallery/fig4_plant.toml").read()
old = "position = [0.0, 0.75, 2.6]"
assert old in text, "fig4_plant.toml: camera position line not found"
text = text.replace(old, f"position = [{2.6 * math.sin(a):.4f}, 0.75, {2.6 * math.cos(a):.4f}]")
open(sys.argv[2], "w").write(text)
PY
  $lamina render "$scene" -o "$gallery/fig4_side_$azimuth.png" --quiet || { rm -f "$scene"; exit 1; }
  rm -f "$scene"
done
$lamina render examples/gallery/fig5_bush_backlit.toml -o "$gallery/fig5_bush_backlit.png" --quiet
if [[ -e ../shared/data/plants/potted_plant_02/potted_plant_02.glb ]]; then
  $lamina render examples/gallery/potted_plant.toml -o "$gallery/potted_plant.png" --quiet
  $lamina render examples/gallery/potted_plant_closeup.toml -o "$gallery/potted_plant_closeup.png" --quiet
else
  echo "skipped potted_plant.png, potted_plant_closeup.png: ../shared/data is not here" >&2
fi
