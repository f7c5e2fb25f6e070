#!/usr/bin/env bash
# Fits `lamina leaf fit` to real measured leaves (USGS Spectral Library v7, via
# bench/spectral/measured_leaves.py) and prints each fit's RMSE and band-mean errors.
# Usage: bench/spectral/fit_measured.sh [OUT_DIR [FIT_FLAGS...]]   (needs pip access once, for
# the data); e.g. `bench/spectral/fit_measured.sh /tmp/fits --band-weight 0`.
set -euo pipefail
root="$(cd "$(dirname "$0")/../.." && pwd)"
out="${1:-/tmp/lamina-fit-measured}"
shift || true
mkdir -p "$out"
cargo build --release -q -p lamina-cli --manifest-path "$root/Cargo.toml"
python3 "$root/bench/spectral/measured_leaves.py" -o "$out/spectra" >/dev/null
for f in "$out"/spectra/*.csv; do
  name="$(basename "$f" .csv)"
  echo "== $name"
  "$root/target/release/lamina" leaf fit --spectrum "$f" -o "$out/$name" --force "$@" 2>&1 \
    | grep -E "pigments|RMSE|    "
done
