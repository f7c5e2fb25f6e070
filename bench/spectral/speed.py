#!/usr/bin/env python3
"""Spectral render speed against RGB, measured side by side: issue 14's bars.

For each scene this runs, in turn and `--repeat` times (interleaved, so the machine's drift
hits every mode alike), the same render at the same spp and seed:

* `rgb`:     the scene as it is (`[film] spectral = "rgb"`);
* `visible`: `--set film.spectral="visible"` (48 bins, six wavelengths per path);
* `bands8`:  `--set film.bands=[...]`, eight Sentinel-2-like bands in one render.

It prints, per scene and mode, the render time lamina reports (best of the repeats and the
median), the part of it spent making the spectral channels' materials and lights, and the
ratios to RGB: `render` = the whole `lamina render` call's render time, `paths` = that
minus the spectral setup (what a longer render converges to). The bars: visible at most
1.5x RGB, eight bands at most 2x.

    python3 bench/spectral/speed.py                         # builds target/release/lamina
    python3 bench/spectral/speed.py --lamina target/release/lamina --repeat 3 --spp 32

Scenes: `examples/pigment_leaves.toml` (three pigment leaves under the physical sun and sky:
shading-bound, almost no traversal), `examples/gallery/fig5_bush_backlit.toml` (an 800-leaf
beech bush of instanced curved leaves, the layered leaf model, back-lit) and the demo bush
exported by `lamina demo --export-bush` (1800 alpha-matted diffuse-transmission cards:
traversal-bound).
"""

import argparse
import json
import statistics
import subprocess
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))
import common  # noqa: E402

BANDS8 = ("film.bands=["
          "{name=\"B2\",center=490,width=65},{name=\"B3\",center=560,width=35},"
          "{name=\"B4\",center=665,width=30},{name=\"B5\",center=705,width=15},"
          "{name=\"B6\",center=740,width=15},{name=\"B8\",center=842,width=115},"
          "{name=\"B11\",center=1610,width=90},{name=\"B12\",center=2190,width=180}]")

MODES = {
    "rgb": [],
    "visible": ["--set", "film.spectral=\"visible\""],
    "bands8": ["--set", BANDS8],
}


def run(binary, scene, mode, spp, threads, out):
    ext = "exr"
    cmd = [str(binary), "render", str(scene), "--spp", str(spp), "--threads", str(threads),
           "--seed", "1", "--quiet", "--force", "-o", str(out / f"{scene.stem}_{mode}.{ext}")]
    cmd += MODES[mode]
    t0 = time.perf_counter()
    r = subprocess.run(cmd, capture_output=True, text=True)
    wall = time.perf_counter() - t0
    if r.returncode != 0:
        sys.exit(f"lamina failed ({r.returncode}):\n{' '.join(cmd)}\n{r.stderr}")
    m = common.SUMMARY_RE.search(r.stderr)
    if not m:
        sys.exit(f"no summary line in:\n{r.stderr}")
    return {"secs": float(m.group(4)), "setup": float(m.group(5) or 0.0), "wall": wall}


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--lamina", help="lamina binary (default: build target/release/lamina)")
    ap.add_argument("--spp", type=int, default=32)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--scenes", default="pigment,fig5,bush",
                    help="comma-separated: pigment, fig5, bush")
    ap.add_argument("--out", default=str(common.DEFAULT_OUT / "spectral_speed"))
    ap.add_argument("--json", help="write the figures here")
    args = ap.parse_args()
    binary = common.lamina_binary(args.lamina)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    scenes = []
    for name in args.scenes.split(","):
        if name == "pigment":
            scenes.append(common.REPO_DIR / "examples/pigment_leaves.toml")
        elif name == "fig5":
            scenes.append(common.REPO_DIR / "examples/gallery/fig5_bush_backlit.toml")
        elif name == "bush":
            d = out / "bush"
            r = subprocess.run([str(binary), "demo", "--export-bush", str(d), "--size", "512",
                                "--force"], capture_output=True, text=True)
            if r.returncode != 0 or not (d / "bush.toml").exists():
                sys.exit(f"demo --export-bush failed:\n{r.stderr}")
            scenes.append(d / "bush.toml")
        else:
            sys.exit(f"unknown scene '{name}' (pigment, fig5, bush)")
    model, cpus = common.cpu_info()
    print(f"{model}, {cpus} CPUs, {args.threads} threads, {args.spp} spp, "
          f"{args.repeat} interleaved repeats{' (a compile is running!)' if common.compile_running() else ''}")
    report = {"generator": "bench/spectral/speed.py", "spp": args.spp, "scenes": []}
    for scene in scenes:
        runs = {m: [] for m in MODES}
        for _ in range(args.repeat):
            for mode in MODES:
                runs[mode].append(run(binary, scene, mode, args.spp, args.threads, out))
        rgb = [r["secs"] for r in runs["rgb"]]
        print(f"\n{scene.relative_to(common.REPO_DIR) if scene.is_relative_to(common.REPO_DIR) else scene}")
        print(f"  {'mode':8} {'best s':>8} {'median s':>9} {'setup s':>8} {'render/RGB':>11} {'paths/RGB':>10}")
        entry = {"scene": scene.name, "modes": {}}
        for mode, rs in runs.items():
            secs = [r["secs"] for r in rs]
            paths = [r["secs"] - r["setup"] for r in rs]
            # Ratios per repeat (each against the RGB run next to it), then the median.
            ratio = statistics.median(s / g for s, g in zip(secs, rgb))
            pratio = statistics.median(p / g for p, g in zip(paths, rgb))
            setup = statistics.median(r["setup"] for r in rs)
            print(f"  {mode:8} {min(secs):8.2f} {statistics.median(secs):9.2f} {setup:8.2f} "
                  f"{ratio:10.2f}x {pratio:9.2f}x")
            entry["modes"][mode] = {"secs": secs, "setup": [r["setup"] for r in rs],
                                    "render_ratio": ratio, "paths_ratio": pratio}
        report["scenes"].append(entry)
    print("\nbars: visible <= 1.5x, bands8 <= 2x (render/RGB)")
    if args.json:
        Path(args.json).write_text(json.dumps(report, indent=1))


if __name__ == "__main__":
    main()
