#!/usr/bin/env python3
"""The Mitsuba comparison's scene, its rays alone: lamina's engine against Mitsuba 3's.

`mitsuba_compare.py` times whole renders. This times only the ray casting, on the three
kinds of rays a path tracer spends its traversal time on, made the same way for both:

* camera: `--spp` rays per pixel, uniformly jittered in the pixel, pixel after pixel;
* bounce: from each camera ray's hit, a cosine-weighted direction about the normal, on
  either side by a coin toss (a diffuse leaf's BSDF sample); also in a scrambled order;
* sun: from each camera ray's hit toward the sun (any hit).

lamina: `target/release/scene_rays` (lamina-bench; with `--embree` also Embree 3 one ray at
a time through lamina-render's Embree backend). Mitsuba 3 (llvm_ad_rgb): the same kinds of
rays (its own random numbers) through `Scene.ray_intersect_preliminary` and `Scene.ray_test`
on whole wavefronts, which Dr.Jit hands to Embree in packets (16 rays per call on an AVX-512
machine); warm times (the first call of each compiles). Same thread count, same machine, one
run after the other.

    python3 bench/mitsuba_rays.py                    # builds scene_rays, 512x512, 64 rays/pixel
    python3 bench/mitsuba_rays.py --embree           # also Embree one ray at a time
    python3 bench/mitsuba_rays.py --no-build --spp 16

Outputs go to out/mitsuba_rays/ (git-ignored).
"""

import argparse
import json
import math
import subprocess
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
import common  # noqa: E402
import mitsuba_compare as mc  # noqa: E402
from common import fmt_table  # noqa: E402


# The file that marks an --out folder as this script's: it writes only into a new or empty
# folder, or one it wrote before (never over files it did not write).
MARK = ".mitsuba_rays"


def claim_out(out):
    if out.exists() and not out.is_dir():
        sys.exit(f"--out {out}: is a file; name a folder")
    out.mkdir(parents=True, exist_ok=True)
    entries = sorted(p.name for p in out.iterdir())
    if entries and MARK not in entries:
        shown = ", ".join(entries[:5]) + (", ..." if len(entries) > 5 else "")
        sys.exit(f"--out {out}: the folder holds files this script did not write ({shown}); "
                 "nothing was changed. Name a new or empty folder.")
    (out / MARK).write_text("written by bench/mitsuba_rays.py\n")


def scene_rays_binary(embree, build):
    exe = common.REPO_DIR / "target" / "release" / "scene_rays"
    if build:
        cmd = ["cargo", "build", "--release", "-p", "lamina-bench", "--bin", "scene_rays"]
        if embree:
            cmd += ["--features", "embree"]
        subprocess.run(cmd, cwd=common.REPO_DIR, check=True)
    if not exe.exists():
        sys.exit(f"{exe} is missing: build it (cargo build --release -p lamina-bench --bin scene_rays)")
    return exe


def write_rays(rays, path):
    """`rays` (a Mitsuba Ray3f) as bench/embree_rays.c reads them: float32, eight per ray
    (origin, tnear = 0, direction, tfar = the ray's maxt), written through a temporary file."""
    import numpy as np
    dr = common.dr
    n = dr.width(rays.o)
    a = np.empty((n, 8), dtype="<f4")
    for k, c in enumerate("xyz"):
        a[:, k] = np.array(getattr(rays.o, c))
        a[:, 4 + k] = np.array(getattr(rays.d, c))
    a[:, 3] = 0.0
    a[:, 7] = np.array(rays.maxt)
    tmp = path.with_suffix(".tmp")
    a.tofile(tmp)
    tmp.replace(path)


def mitsuba_times(scene, size, spp, repeat, dump=None):
    """Warm seconds (best of `repeat` after a compiling call) per ray set, and the rays.
    With `dump` (a folder), also writes the bounce and sun rays there (`write_rays`)."""
    mi, dr = common.mi, common.dr
    n = size * size * spp
    sensor = scene.sensors()[0]
    sampler = mi.load_dict({"type": "independent"})
    sampler.seed(0, n)
    idx = dr.arange(mi.UInt32, n)
    px = idx // spp
    x = mi.Float(px % size) + sampler.next_1d()
    y = mi.Float(px // size) + sampler.next_1d()
    camera, _ = sensor.sample_ray(0.0, 0.5, mi.Point2f(x / size, y / size), mi.Point2f(0.5))
    dr.eval(camera)
    si = scene.ray_intersect(camera)
    dr.eval(si)
    # The camera rays that hit a surface, compacted (as lamina's sets hold only those).
    hits = dr.compress(si.is_valid())
    m = dr.width(hits)
    si = dr.gather(type(si), si, hits)
    u = mi.Point2f(dr.gather(mi.Float, sampler.next_1d(), hits), dr.gather(mi.Float, sampler.next_1d(), hits))
    side = dr.gather(mi.Float, sampler.next_1d(), hits) < 0.5
    local = mi.warp.square_to_cosine_hemisphere(u)
    local.z = dr.select(side, local.z, -local.z)
    # About the geometric normal, as lamina's set (the cards are flat: the same frame).
    frame = mi.Frame3f(si.n)
    bounce = si.spawn_ray(frame.to_world(local))
    sun = dr.normalize(mi.Vector3f(*mc.SUN_DIR))
    shadow = si.spawn_ray(mi.Vector3f(sun))
    # A scrambled order: i -> i * a mod m with a coprime to m (no two neighbours from one pixel).
    a = 2654435761 % m
    while math.gcd(a, m) != 1:
        a += 1
    perm = mi.UInt32((dr.arange(mi.UInt64, m) * a) % m)
    scrambled = dr.gather(mi.Ray3f, bounce, perm)
    dr.eval(bounce, shadow, scrambled)
    if dump is not None:
        write_rays(bounce, dump / "mitsuba_bounce.f32")
        write_rays(shadow, dump / "mitsuba_sun.f32")

    def timed(f):
        best = math.inf
        for k in range(repeat + 1):
            t0 = time.perf_counter()
            r = f()
            dr.eval(r)
            dr.sync_thread()
            if k > 0:  # the first call compiles
                best = min(best, time.perf_counter() - t0)
        return best, r

    rows = {}
    t, r = timed(lambda: scene.ray_intersect_preliminary(camera).t)
    rows["camera"] = (n, dr.count(dr.isfinite(r)), t)
    t, r = timed(lambda: scene.ray_intersect_preliminary(bounce).t)
    rows["bounce"] = (m, dr.count(dr.isfinite(r)), t)
    t, r = timed(lambda: scene.ray_intersect_preliminary(scrambled).t)
    rows["bounce_shuffled"] = (m, dr.count(dr.isfinite(r)), t)
    t, r = timed(lambda: scene.ray_test(shadow))
    rows["sun"] = (m, dr.count(r), t)
    return {k: (int(a), int(b[0] if hasattr(b, "__getitem__") else b), c) for k, (a, b, c) in rows.items()}


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--no-build", action="store_true", help="use target/release/scene_rays as it is")
    ap.add_argument("--embree", action="store_true", help="also Embree 3 one ray at a time (a build with --features embree)")
    ap.add_argument("--spp", type=int, default=64, help="camera rays per pixel")
    ap.add_argument("--size", type=int, default=512, help="image width = height (pixels)")
    ap.add_argument("--cards", type=int, default=4000)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--repeat", type=int, default=3, help="timed runs per set (the best counts)")
    ap.add_argument("--out", default=str(common.DEFAULT_OUT / "mitsuba_rays"))
    ap.add_argument("--write-rays", action="store_true",
                    help="also write Mitsuba's bounce and sun rays (mitsuba_bounce.f32, mitsuba_sun.f32) "
                         "and lamina's (lamina_bounce.f32, lamina_sun.f32) to --out, for bench/embree_rays.c")
    args = ap.parse_args()

    out = Path(args.out).resolve()
    claim_out(out)
    exe = scene_rays_binary(args.embree, not args.no_build)
    mi, dr = common.setup_mitsuba(args.threads)

    cards = mc.make_cards(args.cards)
    common.write_cards_csv(cards, out / "cards.csv")
    scene_toml = out / "scene.toml"
    scene_toml.write_text(mc.lamina_toml(args.size, args.size, args.spp, 8, "cards.csv"))
    common.cards_to_obj(cards, out / "cards.obj")
    common.quad_to_obj(mc.GROUND["corner"], mc.GROUND["edge_u"], mc.GROUND["edge_v"], out / "ground.obj")
    model, ncpu = common.cpu_info()
    print(f"scene: {len(cards)} leaf cards + ground, {args.size}x{args.size}, {args.spp} camera rays "
          f"per pixel, {args.threads} threads; machine: {ncpu} cores, {model}", flush=True)

    report = out / "scene_rays.json"
    cmd = [str(exe), str(scene_toml), "--spp", str(args.spp), "--threads", str(args.threads),
           "--repeat", str(args.repeat), "--json", str(report)]
    if args.embree:
        cmd.append("--embree")
    if args.write_rays:
        # The folder is this script's (claim_out): its earlier ray files may be replaced.
        cmd += ["--write-rays", str(out), "--force"]
    subprocess.run(cmd, check=True)
    lam = json.loads(report.read_text())["rows"]

    scene = mc.mitsuba_scene(args.size, args.size, args.spp, 8, out / "cards.obj", out / "ground.obj")
    mit = mitsuba_times(scene, args.size, args.spp, args.repeat, out if args.write_rays else None)

    def row(engine, s):
        return next((r for r in lam if r["engine"] == engine and r["set"] == s), None)

    rows = []
    for s in ("camera", "camera_one", "bounce", "bounce_shuffled", "sun", "sun_one"):
        lr = row("lamina", s)
        if lr is None:
            continue
        er = row("embree", s)
        m = mit.get({"camera_one": "camera", "sun_one": "sun"}.get(s, s))
        rows.append([
            s, str(lr["rays"]), "%.3f" % lr["seconds"],
            "-" if er is None else "%.3f" % er["seconds"],
            "-" if m is None else "%.3f" % m[2],
            "-" if m is None else "%.2fx" % (m[2] / lr["seconds"]),
        ])
    print(f"\nRay casting alone ({args.threads} threads; seconds, best of {args.repeat}; "
          "ratio = Mitsuba's time / lamina's, above 1 when lamina is faster):")
    print(fmt_table(rows, ["set", "rays (lamina)", "lamina s", "Embree 1-ray s", "Mitsuba s", "ratio"]))
    print("Mitsuba's rays: " + ", ".join(f"{k} {v[0]} rays, {v[1]} hit/blocked" for k, v in mit.items()))


if __name__ == "__main__":
    main()
