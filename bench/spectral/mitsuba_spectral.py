#!/usr/bin/env python3
"""lamina's spectral renders against Mitsuba 3's `llvm_ad_spectral` variant on the same scene
(issue 14, item 6): band means within noise.

The scene is bench/mitsuba_compare.py's (a few thousand `diffuse_transmission` leaf cards above
a diffuse ground, a delta sun and a constant sky, path tracer, lamina max_depth 8 = Mitsuba 9),
its colours given in RGB as lamina's users give them. lamina upsamples them itself; Mitsuba is
given the very spectra lamina uses, written by `lamina spectrum` (reflectances: the Jakob &
Hanika basis; light: that basis times D65 for `visible` renders, times the ASTM G173 solar
spectrum for band renders), so both renderers solve the same spectral problem. Two renders:

* `visible`: lamina `--set film.spectral="visible"` (48 bins, six wavelengths per path) against
  Mitsuba's `hdrfilm` in the spectral variant (four wavelengths per path, CIE 1931 to linear
  sRGB). lamina's radiance has `Y = ∫ L ȳ dλ`; Mitsuba divides by `∫ ȳ dλ` (106.857 nm over
  its 360-830 nm table), so Mitsuba's emitters get lamina's spectra times that integral.
* `bands`: six Sentinel-2-like bands inside Mitsuba's 360-830 nm range, lamina
  `--set film.bands=[...]` (one render, band-mean spectral radiance per channel) against
  Mitsuba's `specfilm` with one box response per band (`∫ L(λ) SRF(λ) dλ`, the SRF of height
  1 / width: the band mean).

Before the scene, two checks against exact values: Mitsuba looking straight at the sky (its
pixel against the band mean, or CIE colour, of lamina's sky spectrum: the units), and both
renderers looking down at the sun-lit diffuse ground alone, against the exact
`∫ ρ(λ) E(λ) dλ cos θ / π` over each band. lamina renders bands with band-mean coefficients
(a product of band means where the exact answer is the band mean of the product), so it can
differ there by the spectra's covariance inside a band; Mitsuba samples wavelengths
continuously. Both deviations carry over to the scene's comparison, so the table also shows
the difference with each renderer's mean divided by its own ratio on that ground (measured
with 2026-12 Mitsuba 3.9.1: its `specfilm` and spectral `hdrfilm` read 0.1-0.3 % above the
exact band integral, lamina's bands within 0.03 % except where a band's spectra vary inside
it, 490 nm at 65 nm wide: -0.17 %).

For each channel it prints both image means (two seeds each, averaged), their difference, its
standard error (from the seed-to-seed pixel differences: SE of one image's mean =
std(pixel difference) / sqrt(2 N)), and z = difference / SE. "Within noise" is |z| < 3.

    python3 bench/spectral/mitsuba_spectral.py                 # builds target/release/lamina
    python3 bench/spectral/mitsuba_spectral.py --lamina target/release/lamina --size 256 --spp 64

Outputs (out/mitsuba_spectral/, git-ignored): the scenes, the spectra, the EXRs of both, and
side_by_side_visible.png (lamina | Mitsuba | |difference| x 10).
"""

import argparse
import math
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))
import common  # noqa: E402
import mitsuba_compare as mc  # noqa: E402

# Mitsuba's CIE_Y_INTEGRAL (include/mitsuba/core/spectrum.h): ∫ ȳ dλ of its 360-830 nm table.
CIE_Y_INTEGRAL = 106.856895

# Sentinel-2 MSI bands 2-7 (centre, width in nm, rounded), all inside 360-830 nm.
BANDS = [("B2", 490, 65), ("B3", 560, 35), ("B4", 665, 30), ("B5", 705, 15), ("B6", 740, 15),
         ("B7", 783, 20)]
GRID = np.arange(360.0, 831.0, 1.0)


def lamina_spectrum(lamina, rgb, out, emission=None):
    """lamina's spectrum of `rgb` on GRID (values per nm), via `lamina spectrum`."""
    cmd = [str(lamina), "spectrum", "--rgb", ",".join("%.9g" % v for v in rgb),
           "--wavelengths", "360:830:1", "-o", str(out), "--force"]
    if emission:
        cmd += ["--emission", emission]
    common.subprocess.run(cmd, check=True, capture_output=True, text=True)
    d = np.loadtxt(out, delimiter=",", comments="#", skiprows=2)
    assert np.allclose(d[:, 0], GRID)
    return d[:, 1]


def regular(values, scale=1.0):
    """A Mitsuba `regular` spectrum on GRID."""
    return {"type": "regular", "wavelength_min": float(GRID[0]), "wavelength_max": float(GRID[-1]),
            "values": ", ".join("%.8g" % (v * scale) for v in values)}


def box_srf(lo, hi):
    """A box response of height 1 / (hi - lo) on [lo, hi] (linear edges 0.05 nm wide)."""
    e = 0.05
    w = [lo - e, lo, hi, hi + e]
    h = 1.0 / (hi - lo)
    return {"type": "irregular", "wavelengths": ", ".join("%.3f" % x for x in w),
            "values": ", ".join("%.8g" % v for v in [0.0, h, h, 0.0])}


def band_mean(values, lo, hi):
    """Mean of a GRID spectrum over [lo, hi] (trapezoid on the 1 nm grid, linear in between)."""
    x = np.linspace(lo, hi, 2001)
    return float(np.mean(np.interp(x, GRID, values)))


def cie_rec709(values):
    """Linear Rec.709 of a GRID spectral radiance in lamina's convention (Y = ∫ L ȳ dλ), with
    the CIE 1931 2° observer at 1 nm from colour-science (pip install colour-science)."""
    import warnings
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # colour-science's notes on missing SciPy/Matplotlib
        import colour
    cmfs = colour.MSDS_CMFS["CIE 1931 2 Degree Standard Observer"]
    bar = np.array([cmfs[float(nm)] for nm in GRID])
    xyz = (values[:, None] * bar).sum(axis=0)
    m = np.array([[3.2404542, -1.5371385, -0.4985314],
                  [-0.9692660, 1.8760108, 0.0415560],
                  [0.0556434, -0.2040259, 1.0572252]])
    return m @ xyz


GROUND_TOML = """# bench/spectral/mitsuba_spectral.py: the sun-lit ground alone, seen from above.
[camera]
position = [0, 1, 0]
look_at = [0, 0, 0]
up = [0, 0, 1]
fov = 10
[film]
width = 64
height = 64
spp = 1024
filter = "box"
[integrator]
type = "path"
max_depth = 1
[[light]]
type = "sun"
direction = {sun}
irradiance = {sun_e}
angular_diameter = 0.0
[[material]]
name = "soil"
type = "diffuse"
reflectance = {soil}
[[object]]
type = "quad"
material = "soil"
corner = [-4.0, 0.0, 4.0]
edge_u = [8.0, 0.0, 0.0]
edge_v = [0.0, 0.0, -8.0]
"""


def exact_ground(spec, mode):
    """The exact radiance of the sun-lit ground per channel."""
    d = np.array(mc.SUN_DIR, dtype=float)
    cos = d[1] / np.linalg.norm(d)
    prod = spec["soil"] * spec[mode]["sun"] * cos / math.pi
    if mode == "visible":
        return cie_rec709(prod)
    return np.array([band_mean(prod, c - w / 2, c + w / 2) for _, c, w in BANDS])


def ground_check(lamina, spec, mode, extra, out):
    """(lamina's, Mitsuba's) ground radiance over the exact one, per channel."""
    mi = common.mi
    arr = lambda v: "[" + ", ".join("%g" % x for x in v) + "]"
    toml = out / "ground_only.toml"
    toml.write_text(GROUND_TOML.format(sun=arr(mc.SUN_DIR), sun_e=arr(mc.SUN_E),
                                       soil=arr(mc.SOIL_R)))
    exr = out / f"ground_only_{mode}.exr"
    common.subprocess.run([str(lamina), "render", str(toml), "--quiet", "--force", "-o", str(exr)]
                          + extra, check=True, capture_output=True)
    names = ["R", "G", "B"] if mode == "visible" else [b[0] for b in BANDS]
    lam = load_lamina_exr(exr, names).reshape(-1, len(names)).mean(axis=0)
    k = CIE_Y_INTEGRAL if mode == "visible" else 1.0
    d = {"type": "scene", "integrator": {"type": "path", "max_depth": 2},
         "sensor": sensor(64, 1024, films(mode)),
         "sun": {"type": "directional", "direction": [-float(x) for x in mc.SUN_DIR],
                 "irradiance": regular(spec[mode]["sun"], k)},
         "ground": {"type": "obj", "filename": str(out / "ground.obj"), "face_normals": True,
                    "bsdf": {"type": "twosided",
                             "bsdf": {"type": "diffuse", "reflectance": regular(spec["soil"])}}}}
    d["sensor"]["to_world"] = mi.ScalarTransform4f().look_at(origin=[0, 1, 0], target=[0, 0, 0],
                                                             up=[0, 0, 1])
    d["sensor"]["fov"] = 10.0
    img, _, _ = mitsuba_render(mi.load_dict(d), 1024, 7, mode)
    mit = img.reshape(-1, img.shape[-1]).mean(axis=0)
    want = exact_ground(spec, mode)
    return names, lam / want, mit / want


def sensor(size, spp, film):
    mi = common.mi
    cam = mc.CAMERA
    return {
        "type": "perspective", "fov": float(cam["fov"]), "fov_axis": "x",
        "near_clip": 1e-3, "far_clip": 1e5,
        "to_world": mi.ScalarTransform4f().look_at(origin=cam["position"], target=cam["look_at"],
                                                   up=cam["up"]),
        "sampler": {"type": "independent", "sample_count": int(spp)},
        "film": dict(film, width=int(size), height=int(size), rfilter={"type": "box"}),
    }


def films(mode):
    if mode == "visible":
        return {"type": "hdrfilm", "pixel_format": "rgb", "component_format": "float32"}
    f = {"type": "specfilm", "component_format": "float32"}
    for name, c, w in BANDS:
        f[name] = box_srf(c - w / 2, c + w / 2)
    return f


def mitsuba_scene(spec, mode, size, spp, depth, out, with_geometry=True):
    mi = common.mi
    k = CIE_Y_INTEGRAL if mode == "visible" else 1.0
    d = {
        "type": "scene",
        "integrator": {"type": "path", "max_depth": depth + 1, "rr_depth": 3},
        "sensor": sensor(size, spp, films(mode)),
        "sky": {"type": "constant", "radiance": regular(spec[mode]["sky"], k)},
    }
    if with_geometry:
        sun = [-float(x) for x in mc.SUN_DIR]
        d["sun"] = {"type": "directional", "direction": sun,
                    "irradiance": regular(spec[mode]["sun"], k)}
        d["leaves"] = {"type": "obj", "filename": str(out / "cards.obj"), "face_normals": True,
                       "bsdf": {"type": "lamina_difftrans",
                                "reflectance": regular(spec["leaf_r"]),
                                "transmittance": regular(spec["leaf_t"])}}
        d["ground"] = {"type": "obj", "filename": str(out / "ground.obj"), "face_normals": True,
                       "bsdf": {"type": "twosided",
                                "bsdf": {"type": "diffuse", "reflectance": regular(spec["soil"])}}}
    else:
        # Only the sky, and the camera looks up into it.
        d["sensor"]["to_world"] = mi.ScalarTransform4f().look_at(origin=[0, 0, 0], target=[0, 1, 0],
                                                                 up=[0, 0, 1])
    return mi.load_dict(d)


def mitsuba_render(scene, spp, seed, mode):
    """(HxWxC numpy image, channel names, seconds)."""
    mi, dr = common.mi, common.dr
    t0 = time.perf_counter()
    img = mi.render(scene, spp=spp, seed=dr.opaque(mi.UInt32, seed))
    dr.eval(img)
    dr.sync_thread()
    secs = time.perf_counter() - t0
    arr = np.array(img)
    if mode == "visible":
        return arr[..., :3], ["R", "G", "B"], secs
    # specfilm: channels in alphabetical order of the SRF names (its docs).
    names = sorted(b[0] for b in BANDS)
    order = [names.index(b[0]) for b in BANDS]
    return arr[..., order], [b[0] for b in BANDS], secs


def load_lamina_exr(path, channels):
    mi = common.mi
    bmp = mi.Bitmap(str(path))
    if channels == ["R", "G", "B"]:
        return np.array(common.load_exr(path), dtype=np.float64)
    names = [f.name for f in bmp.struct_()]
    arr = np.array(bmp)
    out = []
    for c in channels:
        if c not in names:
            sys.exit(f"{path}: no channel {c} (has {names})")
        out.append(arr[..., names.index(c)])
    return np.stack(out, axis=-1).astype(np.float64)


def stats(lam, mit, names, ground_lam, ground_mit):
    """Rows per channel: means, difference, SE, z; then the same with each renderer's mean
    divided by its own deviation on the analytic ground (`ground_*`: rendered / exact)."""
    rows = []
    n = lam[0].shape[0] * lam[0].shape[1]
    worst = 0.0
    for c, name in enumerate(names):
        ml = [float(im[..., c].mean()) for im in lam]
        mm = [float(im[..., c].mean()) for im in mit]
        se_l = float(np.std(lam[0][..., c] - lam[1][..., c])) / math.sqrt(2 * n)
        se_m = float(np.std(mit[0][..., c] - mit[1][..., c])) / math.sqrt(2 * n)
        a, b = np.mean(ml), np.mean(mm)
        se = math.sqrt(0.5 * se_l ** 2 + 0.5 * se_m ** 2)
        z = (a - b) / se if se > 0 else float("inf")
        ac, bc = a / ground_lam[c], b / ground_mit[c]
        zc = (ac - bc) / se if se > 0 else float("inf")
        worst = max(worst, abs(zc))
        rows.append([name, "%.6g" % a, "%.6g" % b, "%+.3f%%" % (100 * (a - b) / b),
                     "%.3f%%" % (100 * se / b), "%+.2f" % z, "%+.3f%%" % (100 * (ac - bc) / bc),
                     "%+.2f" % zc])
    return rows, worst


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--lamina", help="lamina binary (default: cargo build --release -p lamina-cli)")
    ap.add_argument("--no-build", action="store_true")
    ap.add_argument("--size", type=int, default=256)
    ap.add_argument("--spp", type=int, default=64)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--cards", type=int, default=4000)
    ap.add_argument("--max-depth", type=int, default=8)
    ap.add_argument("--modes", default="visible,bands")
    ap.add_argument("--out", default=str(common.DEFAULT_OUT / "mitsuba_spectral"))
    args = ap.parse_args()
    out = Path(args.out).resolve()
    out.mkdir(parents=True, exist_ok=True)
    mi, dr = common.setup_mitsuba(args.threads, cold_cache_dir=Path(tempfile.mkdtemp()),
                                  variant="llvm_ad_spectral")
    lamina = common.lamina_binary(args.lamina, build=not args.no_build)
    model, ncpu = common.cpu_info()

    cards = mc.make_cards(args.cards)
    common.write_cards_csv(cards, out / "cards.csv")
    common.cards_to_obj(cards, out / "cards.obj")
    common.quad_to_obj(mc.GROUND["corner"], mc.GROUND["edge_u"], mc.GROUND["edge_v"],
                       out / "ground.obj")
    scene_toml = out / "scene.toml"
    scene_toml.write_text(mc.lamina_toml(args.size, args.size, args.spp, args.max_depth,
                                         "cards.csv"))

    spec = {
        "leaf_r": lamina_spectrum(lamina, mc.LEAF_R, out / "leaf_r.csv"),
        "leaf_t": lamina_spectrum(lamina, mc.LEAF_T, out / "leaf_t.csv"),
        "soil": lamina_spectrum(lamina, mc.SOIL_R, out / "soil.csv"),
        "visible": {"sun": lamina_spectrum(lamina, mc.SUN_E, out / "sun_d65.csv", "d65"),
                    "sky": lamina_spectrum(lamina, mc.SKY, out / "sky_d65.csv", "d65")},
        "bands": {"sun": lamina_spectrum(lamina, mc.SUN_E, out / "sun_solar.csv", "solar"),
                  "sky": lamina_spectrum(lamina, mc.SKY, out / "sky_solar.csv", "solar")},
    }
    print(f"scene: {len(cards)} diffuse-transmission cards + ground, {args.size}x{args.size}, "
          f"{args.spp} spp, lamina max_depth {args.max_depth} (Mitsuba {args.max_depth + 1}), "
          f"{args.threads} threads; machine: {ncpu} cores, {model}")
    bands_set = "film.bands=[" + ",".join(
        f'{{name="{n}",center={c},width={w}}}' for n, c, w in BANDS) + "]"
    worst_all = 0.0
    for mode in args.modes.split(","):
        # ---- units: Mitsuba looking at the sky alone.
        sky_scene = mitsuba_scene(spec, mode, 32, 256, args.max_depth, out, with_geometry=False)
        sky_img, names, _ = mitsuba_render(sky_scene, 256, 0, mode)
        got = sky_img.reshape(-1, sky_img.shape[-1]).mean(axis=0)
        if mode == "visible":
            want = cie_rec709(spec["visible"]["sky"])
        else:
            want = np.array([band_mean(spec["bands"]["sky"], c - w / 2, c + w / 2)
                             for _, c, w in BANDS])
        print(f"\n[{mode}] units check, Mitsuba's sky pixel / lamina's value: "
              + ", ".join(f"{n} {g / w:.4f}" for n, g, w in zip(names, got, want)))
        extra = ["--set", 'film.spectral="visible"'] if mode == "visible" else ["--set", bands_set]
        gn, gl, gm = ground_check(lamina, spec, mode, extra, out)
        print(f"[{mode}] sun-lit ground / exact: lamina "
              + ", ".join(f"{n} {v:.4f}" for n, v in zip(gn, gl)) + "; Mitsuba "
              + ", ".join(f"{n} {v:.4f}" for n, v in zip(gn, gm)))

        # ---- the scene, two seeds each, alternating.
        scene = mitsuba_scene(spec, mode, args.size, args.spp, args.max_depth, out)
        lam, mit = [], []
        for seed in (0, 1):
            exr = out / f"lamina_{mode}_s{seed}.exr"
            cmd = [str(lamina), "render", str(scene_toml), "--spp", str(args.spp), "--threads",
                   str(args.threads), "--seed", str(seed), "--quiet", "--force", "-o", str(exr)]
            if mode == "visible":
                cmd += ["-o", str(out / f"lamina_{mode}_s{seed}.png")]
            t0 = time.perf_counter()
            r = common.subprocess.run(cmd + extra, capture_output=True, text=True)
            wall = time.perf_counter() - t0
            if r.returncode != 0:
                sys.exit(f"lamina failed:\n{' '.join(cmd + extra)}\n{r.stderr}")
            lam.append(load_lamina_exr(exr, names))
            img, _, secs = mitsuba_render(scene, args.spp, seed, mode)
            mit.append(img.astype(np.float64))
            print(f"[{mode}] seed {seed}: lamina {wall:.2f} s wall, Mitsuba {secs:.2f} s"
                  + (" (includes its JIT compile)" if seed == 0 else " (warm)"), flush=True)
        rows, worst = stats(lam, mit, names, gl, gm)
        worst_all = max(worst_all, worst)
        print(f"[{mode}] image means (two seeds averaged), lamina vs Mitsuba "
              f"({'linear Rec.709' if mode == 'visible' else 'band-mean spectral radiance, W m^-2 sr^-1 nm^-1'}):")
        print(common.fmt_table(rows, ["channel", "lamina", "Mitsuba", "difference", "SE of difference",
                                      "z", "difference, ground-corrected", "z"]))
        if mode == "visible":
            la = 0.5 * (lam[0] + lam[1])
            ma = 0.5 * (mit[0] + mit[1])
            diff = np.abs(la - ma) * 10.0
            row = np.concatenate([la, ma, diff], axis=1)
            scale = 0.2 / max(float(la.mean()), 1e-9)
            png = np.clip(row * scale, 0.0, 1.0)
            png = np.where(png <= 0.0031308, 12.92 * png, 1.055 * np.power(png, 1 / 2.4) - 0.055)
            bmp = mi.Bitmap((png * 255.0 + 0.5).astype(np.uint8), mi.Bitmap.PixelFormat.RGB)
            bmp.write(str(out / "side_by_side_visible.png"))
            # Pixel-level agreement against the noise floor, as bench/mitsuba_compare.py does.
            rmse = float(np.sqrt(np.mean((la - ma) ** 2)))
            noise = math.sqrt(0.25 * (np.mean((lam[0] - lam[1]) ** 2) +
                                      np.mean((mit[0] - mit[1]) ** 2)))
            print(f"[visible] RMSE lamina vs Mitsuba (both seeds averaged) {rmse:.5f}; expected "
                  f"from noise alone {noise:.5f}")
    print(f"\nlargest |z| over all channels, ground-corrected: {worst_all:.2f} "
          + ("(within noise: |z| < 3)" if worst_all < 3 else "(NOT within noise)"))


if __name__ == "__main__":
    main()
