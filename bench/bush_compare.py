#!/usr/bin/env python3
"""The demo bush in lamina and in Mitsuba 3 (llvm_ad_rgb): seconds and samples/s side by side.

`lamina demo --export-bush DIR` writes the bush as an ordinary scene folder (bush.toml,
bush_cards.csv, bush_wood.obj, leaf_alpha.png; diffuse_transmission leaves with an alpha
matte, a delta sun, a constant sky). This script converts that scene to Mitsuba:

* leaf cards -> one OBJ of rectangles with lamina's uv (see common.cards_to_obj);
* alpha matte -> `mask` BSDF with a raw (not sRGB-decoded) bilinear `bitmap` opacity around the
  `lamina_difftrans` BSDF (lamina thresholds the bilinear matte at alpha_cutoff; Mitsuba's mask
  is stochastic, which gives the same coverage on average);
* OBJ branches -> `obj` shape with face normals (lamina shades with geometric normals);
* quad ground -> OBJ quad; diffuse -> `twosided` `diffuse` (lamina's materials are two-sided).

Mitsuba's `path` integrator ignores the mask on shadow rays (a fully transparent card still
blocks the sun: checked in bench/README.md), so with alpha-matted leaves only `volpath` renders
the same image as lamina. Both are timed: `volpath` (the same image) and `path` (faster, wrong
shadows).

    python3 bench/bush_compare.py                       # 512x512, 64 spp, depth 8, 2 threads
    python3 bench/bush_compare.py --lamina target/release/lamina --repeat 2

Outputs in out/bush_compare/ (git-ignored): the exported scene, the renders and
side_by_side.png (lamina | Mitsuba volpath | |difference| x 10).
"""

import argparse
import math
import statistics
import subprocess
import sys
import tempfile
import time
import tomllib
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
import common  # noqa: E402
from common import fmt_table  # noqa: E402


def export_bush(lamina, out, size, spp):
    # The light-sampling variants an earlier run wrote beside bush.toml: lamina refuses to
    # export into a folder holding files it did not write.
    for light in common.LIGHT_SAMPLING:
        for sky in ("",) + common.SKY_SAMPLING:
            mode = light + (":" + sky if sky else "")
            if mode != "all":
                (out / f"bush_{common.mode_tag(mode)}.toml").unlink(missing_ok=True)
    cmd = [str(lamina), "demo", "--export-bush", str(out), "--size", str(size), "--spp", str(spp)]
    r = subprocess.run(cmd, capture_output=True, text=True)
    if r.returncode != 0 or not (out / "bush.toml").exists():
        sys.exit(f"`{' '.join(cmd)}` failed ({r.returncode}); does this lamina have "
                 f"`demo --export-bush`?\n{r.stderr}")
    return out / "bush.toml"


def colour(v, default):
    if v is None:
        v = default
    return common.rgb(v)


def convert(scene_path, out, integrator, spp_override=None, sampler="independent"):
    """The lamina scene at `scene_path` as a Mitsuba scene dict (only what the bush uses:
    sun/constant sky, diffuse/diffuse_transmission with optional alpha, leaf_cards/obj/quad,
    no transforms)."""
    mi = common.mi
    base = scene_path.parent
    sc = tomllib.loads(scene_path.read_text())
    cam, film = sc["camera"], sc.get("film", {})
    if film.get("filter", "gaussian") != "box":
        print("warning: the lamina film filter is not box; Mitsuba uses box", file=sys.stderr)
    integ = sc.get("integrator", {})
    if integ.get("type", "path") != "path":
        sys.exit("only the lamina `path` integrator has a Mitsuba equivalent")
    width, height = film.get("width", 640), film.get("height", 480)
    spp = spp_override or film.get("spp", 64)
    d = {
        "type": "scene",
        "integrator": {"type": integrator, "max_depth": int(integ.get("max_depth", 8)) + 1,
                       "rr_depth": int(integ.get("rr_depth", 3))},
        "sensor": common.mitsuba_sensor(cam["position"], cam["look_at"], cam.get("up", [0, 1, 0]),
                                        cam.get("fov", 40.0), width, height, spp, sampler),
    }
    if cam.get("aperture_radius", 0) > 0:
        sys.exit("thin-lens cameras are not converted")
    sky = sc.get("sky")
    if sky:
        if sky["type"] != "constant":
            sys.exit("only a constant sky is converted")
        s = sky.get("scale", 1.0)
        rad = sky["radiance"]
        rad = [rad * s] * 3 if isinstance(rad, (int, float)) else [x * s for x in rad]
        d["sky"] = common.mitsuba_sky(rad)
    for i, light in enumerate(sc.get("light", [])):
        if light["type"] != "sun" or light.get("angular_diameter", 0.53) != 0:
            sys.exit("only delta suns (angular_diameter = 0) are converted")
        d[f"sun{i}"] = common.mitsuba_sun(light["direction"], light["irradiance"])
    mats = {}
    for m in sc.get("material", []):
        if m["type"] == "diffuse":
            b = {"type": "twosided", "bsdf": {"type": "diffuse",
                                              "reflectance": colour(m.get("reflectance"), 0.5)}}
        elif m["type"] == "diffuse_transmission":
            b = {"type": "lamina_difftrans", "reflectance": colour(m.get("reflectance"), 0.5),
                 "transmittance": colour(m.get("transmittance"), 0.25)}
        else:
            sys.exit(f"material type {m['type']} has no Mitsuba equivalent here")
        if any(k in m for k in ("reflectance_map", "transmittance_map")):
            sys.exit("colour maps are not converted")
        if "alpha" in m:
            b = {"type": "mask", "opacity": {"type": "bitmap", "filename": str(base / m["alpha"]),
                                             "raw": True, "filter_type": "bilinear"},
                 "bsdf": b}
        mats[m["name"]] = b
    ncards = 0
    for i, o in enumerate(sc.get("object", [])):
        if "transform" in o:
            sys.exit("object transforms are not converted")
        bsdf = mats[o["material"]]
        if o["type"] == "leaf_cards":
            cards = []
            if "file" in o:
                if not o["file"].lower().endswith(".csv"):
                    sys.exit("only CSV card files are converted")
                cards += common.read_cards_csv(base / o["file"])
            for c in o.get("cards", []):
                cards.append((c["center"], c["normal"], c["up"], c["width"], c["height"]))
            path = out / f"mitsuba_obj{i}_cards.obj"
            common.cards_to_obj(cards, path)
            ncards += len(cards)
        elif o["type"] == "obj":
            path = base / o["file"]
        elif o["type"] == "quad":
            path = out / f"mitsuba_obj{i}_quad.obj"
            common.quad_to_obj(o["corner"], o["edge_u"], o["edge_v"], path)
        else:
            sys.exit(f"object type {o['type']} is not converted")
        d[f"object{i}"] = {"type": "obj", "filename": str(path), "face_normals": True, "bsdf": bsdf}
    return d, (width, height, spp, ncards)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--lamina", help="lamina binary (default: cargo build --release -p lamina-cli)")
    ap.add_argument("--no-build", action="store_true", help="use target/release/lamina as it is")
    ap.add_argument("--spp", type=int, default=64)
    ap.add_argument("--size", type=int, default=512)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--repeat", type=int, default=2, help="timed runs per renderer (seeds 0, 1, ...)")
    ap.add_argument("--integrators", default="volpath,path",
                    help="Mitsuba integrators to time (volpath: same image as lamina; path: mask "
                         "ignored by shadow rays)")
    ap.add_argument("--mitsuba-sampler", default="independent",
                    help="Mitsuba sampler (independent, stratified, multijitter, orthogonal, ldsampler)")
    ap.add_argument("--light-sampling", default=common.LIGHT_SAMPLING_DEFAULT,
                    help=common.LIGHT_SAMPLING_HELP)
    ap.add_argument("--out", default=str(common.DEFAULT_OUT / "bush_compare"))
    ap.add_argument("--warm-disk-cache", action="store_true",
                    help="reuse Dr.Jit's on-disk kernel cache (default: fresh, so run 1 includes the JIT compile)")
    args = ap.parse_args()
    modes = common.light_sampling_modes(args.light_sampling)

    out = Path(args.out).resolve()
    out.mkdir(parents=True, exist_ok=True)
    cold = None if args.warm_disk_cache else Path(tempfile.mkdtemp(prefix="drjit-cold-"))
    mi, dr = common.setup_mitsuba(args.threads, cold_cache_dir=cold)
    lamina = common.lamina_binary(args.lamina, build=not args.no_build)
    scene_toml = export_bush(lamina, out / "scene", args.size, args.spp)
    model, ncpu = common.cpu_info()
    busy = common.compile_running()

    npix = args.size * args.size * args.spp
    scenes = {}
    for integ in [s.strip() for s in args.integrators.split(",") if s.strip()]:
        d, (w, h, spp, ncards) = convert(scene_toml, out, integ, args.spp, args.mitsuba_sampler)
        t0 = time.perf_counter()
        scenes[integ] = (mi.load_dict(d), time.perf_counter() - t0)
    # lamina and the Mitsuba integrators alternate, run by run, so that all see the same load
    # on a shared machine.
    rows = {}
    lam_imgs = {m: [] for m in modes}
    lam_secs = {m: [] for m in modes}
    mit_imgs = {}
    mit_secs = {}
    for seed in range(args.repeat):
        for m in modes:
            img, wall, summ = common.run_lamina_mode(lamina, scene_toml, out, m, seed, args.spp,
                                                     args.threads)
            lam_imgs[m].append(img)
            lam_secs[m].append(summ["secs"] if summ else wall)
            rows.setdefault(f"lamina {m}", []).append([
                f"lamina light_sampling={m} (run {seed + 1})", "%.2f" % wall,
                "%.2f" % summ["secs"] if summ else "-",
                "%.3f" % (npix / wall / 1e6), "%.3f" % summ["msamples"] if summ else "-",
                "%.2f" % summ["mrays"] if summ else "-"])
            busy = busy or common.compile_running()
        for integ, (scene, load_s) in scenes.items():
            img, secs, st = common.render_mitsuba(scene, args.spp, seed, out / f"mitsuba_{integ}_s{seed}.exr")
            mit_imgs.setdefault(integ, []).append(img)
            mit_secs.setdefault(integ, []).append(secs)
            wall = secs + (load_s if seed == 0 else 0.0)
            note = " (load %.2f s + JIT compile)" % load_s if seed == 0 else " (warm)"
            print(f"Mitsuba {integ} seed {seed}: {wall:.2f} s{note}; {st['kernels']} kernels, "
                  f"{st['cache_hits']} cached, {st['compile_s']:.2f} s codegen+compile", flush=True)
            rows.setdefault(integ, []).append([
                f"Mitsuba {integ} (run {seed + 1}){note}", "%.2f" % wall, "%.2f" % secs,
                "%.3f" % (npix / wall / 1e6), "%.3f" % (npix / secs / 1e6), "-"])
            busy = busy or common.compile_running()
    rows = [r for group in rows.values() for r in group]
    busy = busy or common.compile_running()

    print()
    print(f"Demo bush ({ncards} alpha-matted leaf cards + branches + ground), {args.size}x{args.size}, "
          f"{args.spp} spp, lamina max_depth 8 (Mitsuba 9), {args.threads} threads, Mitsuba sampler {args.mitsuba_sampler}; {ncpu} cores, {model}; "
          f"a compile was {'RUNNING' if busy else 'not running'}")
    print(fmt_table(rows, ["run", "wall s", "render s", "M samples/s (wall)", "M samples/s (render)",
                           "M rays/s"]))
    for integ, secs in mit_secs.items():
        if len(secs) > 1:  # the warm runs (the first includes the JIT compile)
            warm = statistics.median(secs[1:])
            print(f"lamina / Mitsuba {integ} warm at equal spp (render s, median): " + ", ".join(
                f"light_sampling={m} %.2fx" % (statistics.median(lam_secs[m]) / warm)
                for m in modes))
            for m in modes:
                if len(lam_imgs[m]) > 1:
                    lt = statistics.median(lam_secs[m])
                    ratio, el, em = common.equal_error_ratio(lt, lam_imgs[m][:2], warm, mit_imgs[integ][:2])
                    print(f"lamina light_sampling={m} / Mitsuba {integ} ({args.mitsuba_sampler} sampler) "
                          f"at equal error: {ratio:.2f}x (seed-to-seed RMSE lamina {el:.5f}, "
                          f"Mitsuba {em:.5f}; {common.EQUAL_ERROR_NOTE})")

    print()
    crow = []
    for integ, imgs in mit_imgs.items():
        for m in modes:
            c = common.compare(lam_imgs[m][0], imgs[0])
            crow.append([f"lamina {m} vs Mitsuba {integ}", "%.4f" % c["mean_rel"],
                         "%+.2f%%" % (100 * c["means_rel"]), "%.2f%%" % (100 * c["rmse_rel"])])
        if len(imgs) > 1:
            n = common.compare(imgs[0], imgs[1])
            crow.append([f"noise: Mitsuba {integ} s0 vs s1", "%.4f" % n["mean_rel"],
                         "%+.2f%%" % (100 * n["means_rel"]), "%.2f%%" % (100 * n["rmse_rel"])])
    for m in modes:
        if len(lam_imgs[m]) > 1:
            n = common.compare(lam_imgs[m][0], lam_imgs[m][1])
            crow.append([f"noise: lamina {m} s0 vs s1", "%.4f" % n["mean_rel"],
                         "%+.2f%%" % (100 * n["means_rel"]), "%.2f%%" % (100 * n["rmse_rel"])])
    lam_imgs = lam_imgs[modes[0]]
    print("Images (sanity check; a = first, b = second):")
    print(fmt_table(crow, ["pair", "mean rel. diff", "image mean a vs b", "RMSE / mean b"]))

    ref = mit_imgs.get("volpath", next(iter(mit_imgs.values()), None))
    if ref is not None:
        mean = common.image_mean(lam_imgs[0])
        exposure = math.log2(0.2 / max(mean, 1e-9))
        panels = [lam_imgs[0], ref[0], dr.abs(lam_imgs[0] - ref[0]) * 10.0]
        if "path" in mit_imgs and "volpath" in mit_imgs:
            panels.append(mit_imgs["path"][0])
        png = out / "side_by_side.png"
        common.side_by_side_png(panels, png, exposure)
        print(f"\nwrote {png} (lamina | Mitsuba volpath | |difference| x 10"
              + (" | Mitsuba path" if len(panels) > 3 else "") + f"; exposure {exposure:+.2f} stops)")


if __name__ == "__main__":
    main()
