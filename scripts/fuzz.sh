#!/usr/bin/env bash
# The fuzz campaign over lamina's loaders (cargo-fuzz + libFuzzer, nightly toolchain only;
# the project itself builds and tests on stable).
#
#   scripts/fuzz.sh                      # every target, 900 s each, one at a time
#   FUZZ_SECONDS=60 scripts/fuzz.sh gltf obj_mtl
#   FUZZ_JOBS=2 scripts/fuzz.sh          # two targets at once (one per core)
#
# Needs: `rustup toolchain install nightly` and `cargo install cargo-fuzz`.
# Seeds: the repo's example scenes and card file, plus small files made here with the lamina
# binary (a leaf folder, a bush export with CSV cards, OBJ and PNG, a small tree as GLB) and
# by hand (a glTF with an embedded triangle, placements, plant parameters, a few images).
# Corpora grow in fuzz/corpus/<target> and crashes land in fuzz/artifacts/<target> (both
# ignored by git). If libFuzzer stops early (a crash or a timeout) the target is restarted
# for the time left, so every target gets its full time. The summary (executions, coverage
# as edges "cov" and features "ft", corpus size, crashes and timeouts) is printed at the end
# and written to target/fuzz-campaign/summary.md. Every crash found must become a plain
# regression test (crates/*/tests/fuzz_regressions.rs) that `cargo test` runs on stable.
set -euo pipefail
cd "$(dirname "$0")/.."
ROOT=$PWD
SECS=${FUZZ_SECONDS:-900}
JOBS=${FUZZ_JOBS:-1}
ALL="scene_toml gltf obj_mtl cards placements leaf_toml plant_params image_maps"
TARGETS=${*:-$ALL}
OUT=$ROOT/target/fuzz-campaign
SEEDS=$OUT/seeds
mkdir -p "$OUT"

summary() {
    local t=$1 log=$OUT/$1.log execs cov ft corpus crashes timeouts secs
    execs=$(grep -o 'stat::number_of_executed_units: *[0-9]*' "$log" | awk '{s+=$2} END {print s+0}' || true)
    cov=$(grep -oE '(INITED|DONE|pulse|NEW|REDUCE) +cov: [0-9]+' "$log" | awk '{print $3}' | sort -n | tail -1 || true)
    ft=$(grep -oE 'ft: [0-9]+' "$log" | awk '{print $2}' | sort -n | tail -1 || true)
    corpus=$(find "fuzz/corpus/$t" -type f | wc -l || true)
    crashes=$(find "fuzz/artifacts/$t" -type f \( -name 'crash-*' -o -name 'oom-*' -o -name 'leak-*' \) | wc -l || true)
    timeouts=$(find "fuzz/artifacts/$t" -type f -name 'timeout-*' | wc -l || true)
    secs=$(grep -oE 'Done [0-9]+ runs in [0-9]+ second' "$log" | awk '{s+=$5} END {print s+0}' || true)
    echo "| $t | $secs | ${execs:-0} | ${cov:-?} | ${ft:-?} | $corpus | $crashes | $timeouts |"
}

print_summary() {
    {
        echo "| target | seconds fuzzed | executions | edges (cov) | features (ft) | corpus | crashes | timeouts |"
        echo "|---|---|---|---|---|---|---|---|"
        for t in $TARGETS; do summary "$t"; done
    } | tee "$OUT/summary.md"
}

# FUZZ_SUMMARY_ONLY=1: print the table of the last campaign's logs and stop.
if [ -n "${FUZZ_SUMMARY_ONLY:-}" ]; then print_summary; exit 0; fi

command -v cargo-fuzz >/dev/null || { echo "cargo-fuzz is not installed: cargo install cargo-fuzz" >&2; exit 1; }

# ---- seeds -------------------------------------------------------------------------------
cargo build --release -q -p lamina-cli
LAMINA=$ROOT/target/release/lamina
rm -rf "$SEEDS"
for t in $ALL; do mkdir -p "$SEEDS/$t"; done
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
"$LAMINA" leaf generate -r 32 -o "$tmp/leaf" 2>/dev/null
"$LAMINA" demo --export-bush "$tmp/bush" --size 32 --spp 1 2>/dev/null
"$LAMINA" plant generate --kind bush --leaves 12 --leaf-resolution 16 --variants 1 -o "$tmp/tiny.glb" 2>/dev/null
cp examples/*.toml examples/gallery/*.toml "$tmp/bush/bush.toml" "$SEEDS/scene_toml/"
cp "$tmp/leaf/leaf.toml" "$SEEDS/leaf_toml/"
cp examples/cards.csv "$tmp"/bush/bush_cards_0.csv "$SEEDS/cards/"
cp "$tmp/tiny.glb" "$SEEDS/gltf/"
cp "$tmp/leaf/alpha.png" "$tmp/leaf/front.png" "$tmp/bush/leaf_alpha_0.png" "$SEEDS/image_maps/"
head -c 4000 "$tmp/bush/bush_wood.obj" | sed '$d' > "$SEEDS/obj_mtl/wood.obj"
python3 - "$SEEDS" <<'EOF'
import base64, json, struct, sys, os, zlib
seeds = sys.argv[1]
def w(target, name, data):
    mode = 'wb' if isinstance(data, bytes) else 'w'
    with open(os.path.join(seeds, target, name), mode) as f:
        f.write(data)
# A glTF with one indexed, textured triangle in a data URI (positions, normals, uvs, indices).
pos = struct.pack('<9f', 0, 0, 0, 1, 0, 0, 0, 1, 0)
nor = struct.pack('<9f', 0, 0, 1, 0, 0, 1, 0, 0, 1)
uv = struct.pack('<6f', 0, 0, 1, 0, 0, 1)
idx = struct.pack('<3H', 0, 1, 2) + b'\0\0'
buf = pos + nor + uv + idx
g = {
  "asset": {"version": "2.0"},
  "buffers": [{"byteLength": len(buf), "uri": "data:application/octet-stream;base64," + base64.b64encode(buf).decode()}],
  "bufferViews": [
    {"buffer": 0, "byteOffset": 0, "byteLength": 36},
    {"buffer": 0, "byteOffset": 36, "byteLength": 36},
    {"buffer": 0, "byteOffset": 72, "byteLength": 24},
    {"buffer": 0, "byteOffset": 96, "byteLength": 6}],
  "accessors": [
    {"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3", "min": [0, 0, 0], "max": [1, 1, 0]},
    {"bufferView": 1, "componentType": 5126, "count": 3, "type": "VEC3"},
    {"bufferView": 2, "componentType": 5126, "count": 3, "type": "VEC2"},
    {"bufferView": 3, "componentType": 5123, "count": 3, "type": "SCALAR"}],
  "materials": [{"pbrMetallicRoughness": {"baseColorFactor": [0.2, 0.5, 0.1, 1], "metallicFactor": 0, "roughnessFactor": 0.6}}],
  "meshes": [{"primitives": [{"attributes": {"POSITION": 0, "NORMAL": 1, "TEXCOORD_0": 2}, "indices": 3, "material": 0}]}],
  "nodes": [{"mesh": 0, "translation": [0, 1, 0]}, {"mesh": 0, "scale": [2, 2, 2]}],
  "scenes": [{"nodes": [0, 1]}], "scene": 0}
w('gltf', 'triangle.gltf', json.dumps(g))
# OBJ with an MTL after the #MTL separator the obj_mtl target splits on.
w('obj_mtl', 'quad.obj', "mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nvn 0 0 1\nusemtl leaf\nf 1/1/1 2/2/1 3/3/1 4/4/1\n"
  "#MTL\nnewmtl leaf\nKd 0.2 0.5 0.1\nKs 0.04 0.04 0.04\nNs 40\nPr 0.5\nmap_Kd -s 2 2 1 leaf.png\nnorm n.png\n")
w('cards', 'cards.json', json.dumps([{"center": [0, 1, 0], "normal": [0, 0, 1], "up": [0, 1, 0], "width": 0.1, "height": 0.2}]))
w('placements', 'p.csv', "tx,ty,tz,rotate_y,scale\n0,0,0,0,1\n3,0,-2,45,1.2\n-1e3,0,5,-720,0.5\n")
w('placements', 'p2.csv', "tx,ty,tz,rx,ry,rz,sx,sy,sz\n1,2,3,10,20,30,1,2,-1\n")
w('plant_params', 'tree.toml', 'kind = "tree"\nseed = 3\nspecies = "beech"\nheight_m = 10\nleaf_count = 30000\nleaf_scale = 1.8\nleaf_resolution = 64\ncrown_shape = "cone"\n')
w('plant_params', 'bush.toml', 'kind = "bush"\nleaf_variants = 3\nphototropism = 0.5\ngravitropism = 0.2\n')
w('leaf_toml', 'hand.toml', '[maps]\nfront = "f.png"\nwrap = "repeat"\n[params]\nthickness_mm = 0.3\n')
# Small images: a 16-bit grey PNG and a Radiance HDR.
def png(w_, h, bitdepth, colortype, raw):
    def chunk(t, d): return struct.pack('>I', len(d)) + t + d + struct.pack('>I', zlib.crc32(t + d) & 0xffffffff)
    ihdr = struct.pack('>IIBBBBB', w_, h, bitdepth, colortype, 0, 0, 0)
    return b'\x89PNG\r\n\x1a\n' + chunk(b'IHDR', ihdr) + chunk(b'IDAT', zlib.compress(raw)) + chunk(b'IEND', b'')
w('image_maps', 'g16.png', png(2, 2, 16, 0, b'\0\x00\x10\x00\xff\xff' + b'\0\x80\x00\x00\x01'))
w('image_maps', 'tiny.hdr', b'#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 1 +X 2\n' + bytes([128, 64, 32, 129, 10, 20, 30, 128]))
EOF
# OBJ seeds carry their MTL after the separator; give the bush's wood one too.
printf '#MTL\nnewmtl bark\nKd 0.1 0.07 0.05\n' >> "$SEEDS/obj_mtl/wood.obj"

# ---- campaign ----------------------------------------------------------------------------
cargo +nightly fuzz build -O --fuzz-dir fuzz >/dev/null 2>&1 || cargo +nightly fuzz build -O --fuzz-dir fuzz

run_target() {
    local t=$1 log=$OUT/$1.log start now left runs=0
    : > "$log"
    mkdir -p "fuzz/corpus/$t" "fuzz/artifacts/$t"
    start=$(date +%s)
    while :; do
        now=$(date +%s); left=$((SECS - (now - start)))
        [ "$left" -gt 5 ] || break
        runs=$((runs + 1))
        # -timeout: an input that runs 20 s is a hang worth a look, not a slow parse.
        "fuzz/target/x86_64-unknown-linux-gnu/release/$t" "fuzz/corpus/$t" "$SEEDS/$t" \
            -artifact_prefix="fuzz/artifacts/$t/" -max_total_time="$left" -timeout=20 \
            -rss_limit_mb=4096 -max_len=65536 -print_final_stats=1 >>"$log" 2>&1 || true
    done
    echo "runs: $runs" >>"$log"
}

export -f run_target
export SECS OUT SEEDS
printf '%s\n' $TARGETS | xargs -P "$JOBS" -I{} bash -c 'run_target {}'

print_summary
