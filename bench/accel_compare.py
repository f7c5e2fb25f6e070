#!/usr/bin/env python3
"""Whole renders on lamina's own ray-casting engine against the same renders on Embree 3
(`lamina render --accel embree`): seconds and M rays/s side by side, and the images
(read back with Mitsuba 3's EXR reader, `pip install mitsuba`).

Each scene is rendered with both engines in turn (`--repeat` rounds, interleaved so that the
machine's drift hits both alike), with the same seed: the two renders trace the same samples,
so their images differ only where the engines disagree on a hit (grazing rays, edges shared
by two triangles) and the mean relative difference is far below the noise of a second seed,
which is printed next to it.

Needs a lamina built with Embree (Debian: `apt-get install -y libembree-dev`):

    cargo build --release -p lamina-cli --features embree
    python3 bench/accel_compare.py --lamina target/release/lamina
    python3 bench/accel_compare.py --lamina target/release/lamina --spp 32 --repeat 3

Scenes: the demo bush (exported with `lamina demo --export-bush`), examples/leaf_cards.toml,
examples/plant.toml and examples/forest.toml, or the scene files given with --scene.
Outputs in out/accel_compare/ (git-ignored).
"""

import argparse
import subprocess
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
import common  # noqa: E402
from common import fmt_table  # noqa: E402


def render(lamina, scene, out, spp, threads, seed, accel):
    cmd = [str(lamina), "render", str(scene), "-o", str(out), "--spp", str(spp),
           "--threads", str(threads), "--seed", str(seed), "--accel", accel, "--quiet", "--force"]
    r = subprocess.run(cmd, capture_output=True, text=True)
    if r.returncode != 0:
        sys.exit(f"`{' '.join(cmd)}` failed ({r.returncode}):\n{r.stderr}")
    m = common.SUMMARY_RE.search(r.stderr)
    if not m:
        sys.exit(f"no summary line from `{' '.join(cmd)}`:\n{r.stderr}")
    return float(m.group(4)), float(m.group(7))


def main():
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--lamina", required=True, help="a lamina built with --features embree")
    ap.add_argument("--scene", action="append", help="scene files (default: see above)")
    ap.add_argument("--spp", type=int, default=16)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--repeat", type=int, default=2)
    ap.add_argument("--out", default=str(common.DEFAULT_OUT / "accel_compare"))
    a = ap.parse_args()
    lamina = common.lamina_binary(a.lamina, build=False)
    # Mitsuba only reads the EXRs here.
    common.setup_mitsuba(a.threads)
    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    if a.scene:
        scenes = [Path(s) for s in a.scene]
    else:
        bush = out / "bush"
        r = subprocess.run([str(lamina), "demo", "--export-bush", str(bush), "--size", "512",
                            "--spp", str(a.spp)], capture_output=True, text=True)
        if r.returncode != 0:
            sys.exit(f"lamina demo --export-bush failed:\n{r.stderr}")
        ex = common.REPO_DIR / "examples"
        scenes = [bush / "bush.toml", ex / "leaf_cards.toml", ex / "plant.toml", ex / "forest.toml"]
    model, cores = common.cpu_info()
    print(f"machine: {model}, {cores} cores; {a.threads} threads, {a.spp} spp, "
          f"{a.repeat} rounds interleaved", flush=True)
    rows = []
    for scene in scenes:
        name = scene.stem
        times = {"lamina": [], "embree": []}
        rays = {"lamina": [], "embree": []}
        for k in range(a.repeat):
            for accel in ("lamina", "embree") if k % 2 == 0 else ("embree", "lamina"):
                secs, mrays = render(lamina, scene, out / f"{name}_{accel}.exr", a.spp,
                                     a.threads, 1, accel)
                times[accel].append(secs)
                rays[accel].append(mrays)
        render(lamina, scene, out / f"{name}_lamina_seed2.exr", a.spp, a.threads, 2, "lamina")
        img = {k: common.load_exr(out / f"{name}_{k}.exr")
               for k in ("lamina", "embree", "lamina_seed2")}
        same_seed = common.compare(img["embree"], img["lamina"])
        noise = common.compare(img["lamina_seed2"], img["lamina"])
        tl, te = min(times["lamina"]), min(times["embree"])
        rows.append([name, f"{tl:.2f}", f"{te:.2f}", f"{te / tl:.2f}",
                     f"{max(rays['lamina']):.2f}", f"{max(rays['embree']):.2f}",
                     f"{100 * same_seed['means_rel']:+.3f} %",
                     f"{same_seed['mean_rel']:.4f}", f"{noise['mean_rel']:.4f}"])
        print(f"{name}: lamina {times['lamina']} s, embree {times['embree']} s", flush=True)
    print()
    print(fmt_table(rows, ["scene", "lamina s", "Embree s", "Embree / lamina",
                           "lamina M rays/s", "Embree M rays/s", "mean, Embree vs lamina",
                           "mean |rel diff|, same seed", "the same, another seed (noise)"]))


if __name__ == "__main__":
    main()
