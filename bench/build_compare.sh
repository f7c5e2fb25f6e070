#!/bin/bash
# Build time of lamina-accel (AVX2 kernel) against Embree 3 on 1M random cards, interleaved
# rounds of the throughput example, with min and median of each and their ratios.
#   bench/build_compare.sh [ROUNDS] [BINARY...]
# Without binaries it builds the example (`--features embree`, needs libembree-dev); with
# several (e.g. the example built at two commits) they alternate round by round.
set -euo pipefail
rounds=${1:-8}
if ! [[ "$rounds" =~ ^[1-9][0-9]*$ ]]; then
  echo "build_compare.sh: ROUNDS must be a whole number of rounds, at least 1 (got '$rounds')" >&2
  exit 2
fi
shift || true
bins=("$@")
for b in "${bins[@]}"; do
  [ -x "$b" ] || { echo "build_compare.sh: '$b' is not an executable (the throughput example)" >&2; exit 2; }
done
if [ ${#bins[@]} -eq 0 ]; then
  cargo build --release -q -p lamina-accel --features embree --example throughput
  bins=(target/release/examples/throughput)
fi
for _ in $(seq "$rounds"); do
  for b in "${bins[@]}"; do
    LAMINA_BUILD_ONLY=1 "$b" 1000000 | grep -E "Embree|Avx2" | sed "s|^|$b |"
  done
done | python3 -c '
import sys, re, collections, statistics
d = collections.defaultdict(list)
for line in sys.stdin:
    m = re.match(r"(\S+) +\d+ cards (\w+): build ([0-9.]+)", line)
    d[(m[1], m[2])].append(float(m[3]))
for b in dict.fromkeys(k[0] for k in d):
    l, e = d[(b, "Avx2")], d[(b, "Embree")]
    print(f"{b}: lamina min {min(l):.3f} s, median {statistics.median(l):.3f} s; "
          f"Embree min {min(e):.3f} s, median {statistics.median(e):.3f} s; "
          f"lamina / Embree: mins {min(l) / min(e):.2f}x, medians "
          f"{statistics.median(l) / statistics.median(e):.2f}x ({len(l)} rounds)")
'
