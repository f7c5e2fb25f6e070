"""Shared helpers for the lamina <-> Mitsuba 3 comparisons in bench/.

* `setup_mitsuba()`: selects the `llvm_ad_rgb` variant (with a libLLVM that Dr.Jit can use), sets
  the thread count, and registers the `lamina_difftrans` BSDF.
* `DiffuseTransmissionBSDF`: Lambertian reflection R/pi on the side of wi plus Lambertian
  transmission T/pi to the other side, two-sided, the reflection lobe picked with probability
  lum(R) / (lum(R) + lum(T)): the same as `DiffuseTransmission` in
  crates/lamina-leaf/src/lambert.rs.
* lamina: build or locate the binary, run it with timing, parse its summary line.
* images: load EXRs as Dr.Jit tensors (no numpy needed), compare, write side-by-side PNGs.

Conventions (checked by mitsuba_compare.py, see bench/README.md):
* lamina `max_depth` counts scattering events; Mitsuba's counts path vertices including the
  emitter hit, so Mitsuba max_depth = lamina max_depth + 1.
* lamina sun `direction` points *toward* the sun; Mitsuba `directional.direction` is the
  direction light travels, so it is the negated vector. Both take irradiance (W m^-2) on a
  surface facing the sun.
* lamina `sky.type = "constant"` = Mitsuba `constant` emitter with the same radiance.
* box pixel filter in both; horizontal fov (`fov_axis = "x"`).
"""

import os
import re
import subprocess
import sys
import time
from pathlib import Path

BENCH_DIR = Path(__file__).resolve().parent
REPO_DIR = BENCH_DIR.parent
DEFAULT_OUT = REPO_DIR / "out"

_LLVM_CANDIDATES = [
    "/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1",
    "/usr/lib/x86_64-linux-gnu/libLLVM-19.so",
    "/usr/lib/llvm-19/lib/libLLVM.so.1",
    "/usr/lib/llvm-19/lib/libLLVM-19.so",
]

mi = None
dr = None


def setup_mitsuba(threads, cold_cache_dir=None, variant="llvm_ad_rgb"):
    """Imports Mitsuba with `variant` (default `llvm_ad_rgb`; bench/spectral uses
    `llvm_ad_spectral`) and `threads` Dr.Jit worker threads.

    `cold_cache_dir`: when given, Dr.Jit's on-disk kernel cache (~/.drjit) is redirected
    there (HOME is changed before the import), so the first render pays the full JIT
    compile, as it does on a fresh machine.
    """
    global mi, dr
    if "DRJIT_LIBLLVM_PATH" not in os.environ:
        for c in _LLVM_CANDIDATES:
            if os.path.exists(c):
                os.environ["DRJIT_LIBLLVM_PATH"] = c
                break
    if cold_cache_dir is not None:
        os.makedirs(cold_cache_dir, exist_ok=True)
        os.environ["HOME"] = str(cold_cache_dir)
    import drjit as _dr
    import mitsuba as _mi

    _mi.set_variant(variant)
    _mi.set_log_level(_mi.LogLevel.Warn)
    _dr.set_thread_count(threads)
    _dr.set_flag(_dr.JitFlag.KernelHistory, True)
    mi, dr = _mi, _dr
    _register_bsdf()
    return mi, dr


def _register_bsdf():
    class DiffuseTransmissionBSDF(mi.BSDF):
        """R/pi reflection + T/pi transmission, two-sided (lamina `diffuse_transmission`)."""

        def __init__(self, props):
            mi.BSDF.__init__(self, props)
            self.reflectance = props.get("reflectance", 0.5)
            self.transmittance = props.get("transmittance", 0.25)
            if not isinstance(self.reflectance, mi.Texture):
                self.reflectance = mi.load_dict({"type": "rgb", "value": self.reflectance})
            if not isinstance(self.transmittance, mi.Texture):
                self.transmittance = mi.load_dict({"type": "rgb", "value": self.transmittance})
            two = mi.BSDFFlags.FrontSide | mi.BSDFFlags.BackSide
            refl = mi.BSDFFlags.DiffuseReflection | two
            trans = mi.BSDFFlags.DiffuseTransmission | two
            self.m_components = [refl, trans]
            self.m_flags = refl | trans

        def _lobes(self, ctx, si, active):
            r = self.reflectance.eval(si, active)
            t = self.transmittance.eval(si, active)
            # Any lobe choice is unbiased; this one is lamina's (Rec.709 luminance; in a
            # spectral variant, the luminance of the path's wavelengths).
            if mi.is_spectral:
                lr = dr.maximum(mi.luminance(r, si.wavelengths, active), 0.0)
                lt = dr.maximum(mi.luminance(t, si.wavelengths, active), 0.0)
            else:
                lr = dr.maximum(mi.luminance(r), 0.0)
                lt = dr.maximum(mi.luminance(t), 0.0)
            pr = dr.select(lr + lt > 0.0, lr / (lr + lt), 0.5)
            has_r = ctx.is_enabled(mi.BSDFFlags.DiffuseReflection, 0)
            has_t = ctx.is_enabled(mi.BSDFFlags.DiffuseTransmission, 1)
            if not has_r:
                pr = mi.Float(0.0)
            if not has_t:
                pr = mi.Float(1.0)
            if not has_r:
                r = mi.Spectrum(0.0)
            if not has_t:
                t = mi.Spectrum(0.0)
            return r, t, pr

        def sample(self, ctx, si, sample1, sample2, active):
            cos_i = mi.Frame3f.cos_theta(si.wi)
            r, t, pr = self._lobes(ctx, si, active)
            reflect = sample1 < pr
            wo = mi.warp.square_to_cosine_hemisphere(sample2)
            # Reflection stays on the side of wi, transmission crosses to the other.
            same = dr.select(cos_i > 0.0, 1.0, -1.0)
            wo.z = wo.z * dr.select(reflect, same, -same)
            lobe = dr.select(reflect, pr, 1.0 - pr)
            bs = mi.BSDFSample3f()
            bs.wo = wo
            bs.pdf = lobe * dr.abs(wo.z) * dr.inv_pi
            bs.eta = 1.0
            bs.sampled_component = dr.select(reflect, mi.UInt32(0), mi.UInt32(1))
            bs.sampled_type = dr.select(
                reflect,
                mi.UInt32(+mi.BSDFFlags.DiffuseReflection),
                mi.UInt32(+mi.BSDFFlags.DiffuseTransmission),
            )
            ok = active & (cos_i != 0.0) & (bs.pdf > 0.0)
            # f |cos| / pdf = colour / lobe probability.
            value = dr.select(reflect, r, t) / lobe
            bs.pdf = dr.select(ok, bs.pdf, 0.0)
            return bs, dr.select(ok, value, mi.Spectrum(0.0))

        def _eval_pdf(self, ctx, si, wo, active):
            cos_i = mi.Frame3f.cos_theta(si.wi)
            r, t, pr = self._lobes(ctx, si, active)
            c = cos_i * mi.Frame3f.cos_theta(wo)
            cosw = dr.abs(mi.Frame3f.cos_theta(wo)) * dr.inv_pi
            f = dr.select(c > 0.0, r, dr.select(c < 0.0, t, mi.Spectrum(0.0))) * cosw
            lobe = dr.select(c > 0.0, pr, dr.select(c < 0.0, 1.0 - pr, 0.0))
            f = dr.select(active, f, mi.Spectrum(0.0))
            pdf = dr.select(active, lobe * cosw, 0.0)
            return f, pdf

        def eval(self, ctx, si, wo, active):
            return self._eval_pdf(ctx, si, wo, active)[0]

        def pdf(self, ctx, si, wo, active):
            return self._eval_pdf(ctx, si, wo, active)[1]

        def eval_pdf(self, ctx, si, wo, active):
            return self._eval_pdf(ctx, si, wo, active)

        def traverse(self, callback):
            callback.put("reflectance", self.reflectance, mi.ParamFlags.NonDifferentiable)
            callback.put("transmittance", self.transmittance, mi.ParamFlags.NonDifferentiable)

        def to_string(self):
            return f"LaminaDiffuseTransmission[R={self.reflectance}, T={self.transmittance}]"

    mi.register_bsdf("lamina_difftrans", lambda props: DiffuseTransmissionBSDF(props))


# ---------------------------------------------------------------- Mitsuba scene pieces

def rgb(v):
    if isinstance(v, (int, float)):
        v = [v, v, v]
    return {"type": "rgb", "value": [float(x) for x in v]}


def mitsuba_sensor(position, look_at, up, fov_deg, width, height, spp, sampler="independent"):
    return {
        "type": "perspective",
        "fov": float(fov_deg),
        "fov_axis": "x",
        "near_clip": 1e-3,
        "far_clip": 1e5,
        "to_world": mi.ScalarTransform4f().look_at(origin=position, target=look_at, up=up),
        "sampler": {"type": sampler, "sample_count": int(spp)},
        "film": {
            "type": "hdrfilm",
            "width": int(width),
            "height": int(height),
            "pixel_format": "rgb",
            "component_format": "float32",
            "rfilter": {"type": "box"},
        },
    }


def mitsuba_sun(direction_to_sun, irradiance):
    d = [-float(x) for x in direction_to_sun]  # Mitsuba: direction of travel
    return {"type": "directional", "direction": d, "irradiance": rgb(irradiance)}


def mitsuba_sky(radiance):
    return {"type": "constant", "radiance": rgb(radiance)}


def cards_to_obj(cards, path):
    """Writes leaf cards as an OBJ (two triangles each, v/vt), with the vertex order and uv of
    crates/lamina-scene/src/cards.rs `append_cards`: u along right = up x normal, v along up
    (v = 0 at the base), counter-clockwise seen from the adaxial normal. Mitsuba's OBJ loader
    flips v and its bitmaps have v = 0 at the top row, so an image is oriented as in lamina."""
    lines = ["# leaf cards (generated by bench/)"]
    for c in cards:
        (cx, cy, cz), n, up, w, h = c
        n = _normalize(n)
        up = _sub(up, _scale(n, _dot(n, up)))
        up = _normalize(up)
        right = _cross(up, n)
        r = _scale(right, 0.5 * w)
        u = _scale(up, 0.5 * h)
        ctr = (cx, cy, cz)
        for p in (_sub(_sub(ctr, r), u), _sub(_add(ctr, r), u), _add(_add(ctr, r), u), _add(_sub(ctr, r), u)):
            lines.append("v %.7g %.7g %.7g" % p)
    lines += ["vt 0 0", "vt 1 0", "vt 1 1", "vt 0 1"]
    for i in range(len(cards)):
        b = 4 * i + 1
        lines.append(f"f {b}/1 {b + 1}/2 {b + 2}/3")
        lines.append(f"f {b}/1 {b + 2}/3 {b + 3}/4")
    Path(path).write_text("\n".join(lines) + "\n")


def quad_to_obj(corner, edge_u, edge_v, path):
    p0 = tuple(corner)
    p1 = _add(p0, edge_u)
    p2 = _add(p1, edge_v)
    p3 = _add(p0, edge_v)
    text = "".join("v %.7g %.7g %.7g\n" % p for p in (p0, p1, p2, p3))
    text += "vt 0 0\nvt 1 0\nvt 1 1\nvt 0 1\nf 1/1 2/2 3/3\nf 1/1 3/3 4/4\n"
    Path(path).write_text(text)


def read_cards_csv(path):
    """Reads a lamina leaf-card CSV: list of (center, normal, up, width, height)."""
    cards = []
    header = None
    for line in Path(path).read_text().splitlines():
        s = line.strip()
        if not s or s.startswith("#"):
            continue
        cells = [x.strip() for x in s.split(",")]
        if header is None:
            header = [x.lower() for x in cells]
            continue
        row = dict(zip(header, (float(x) for x in cells)))
        cards.append((
            (row["cx"], row["cy"], row["cz"]),
            (row["nx"], row["ny"], row["nz"]),
            (row["ux"], row["uy"], row["uz"]),
            row["width"],
            row["height"],
        ))
    return cards


def read_rows(path):
    """The rows of a CSV lamina writes (its `# lamina` mark and comments skipped) as dicts
    keyed by the header's names, values as strings."""
    rows, header = [], None
    with open(path) as f:
        for line in f:
            if line.startswith("#"):
                continue
            if header is None:
                header = line.strip().split(",")
                continue
            rows.append(dict(zip(header, line.strip().split(","))))
    return rows


def write_cards_csv(cards, path):
    lines = ["# leaf cards: centre (m), adaxial normal, up (toward the tip), width and height (m)",
             "cx,cy,cz,nx,ny,nz,ux,uy,uz,width,height"]
    for (c, n, u, w, h) in cards:
        lines.append(",".join("%.6f" % x for x in (*c, *n, *u, w, h)))
    Path(path).write_text("\n".join(lines) + "\n")


def _add(a, b):
    return (a[0] + b[0], a[1] + b[1], a[2] + b[2])


def _sub(a, b):
    return (a[0] - b[0], a[1] - b[1], a[2] - b[2])


def _scale(a, s):
    return (a[0] * s, a[1] * s, a[2] * s)


def _dot(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def _cross(a, b):
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def _normalize(a):
    n = _dot(a, a) ** 0.5
    return _scale(a, 1.0 / n)


def render_mitsuba(scene, spp, seed, out_exr=None):
    """Renders `scene` and forces evaluation. Returns (image tensor HxWx3, seconds, kernel
    stats dict: number of kernels, compile seconds, whether all came from a cache)."""
    dr.kernel_history_clear()
    t0 = time.perf_counter()
    img = mi.render(scene, spp=spp, seed=dr.opaque(mi.UInt32, seed))
    dr.eval(img)
    dr.sync_thread()
    secs = time.perf_counter() - t0
    hist = dr.kernel_history()
    compile_s = sum(h.get("backend_time", 0.0) + h.get("codegen_time", 0.0) for h in hist) / 1000.0
    exec_s = sum(h.get("execution_time", 0.0) for h in hist) / 1000.0
    hits = [bool(h.get("cache_hit", False)) for h in hist]
    stats = {"kernels": len(hist), "compile_s": compile_s, "exec_s": exec_s,
             "cache_hits": sum(hits)}
    if out_exr is not None:
        mi.Bitmap(img).write(str(out_exr))
    return img, secs, stats


# ---------------------------------------------------------------- lamina

SUMMARY_RE = re.compile(
    r"(\d+)x(\d+), (\d+) spp in ([0-9.]+) s(?: \(([0-9.]+) s of it making [^)]*\))?: "
    r"([0-9.]+) M samples/s, ([0-9.]+) M rays/s")


def lamina_binary(explicit=None, build=True):
    if explicit:
        p = Path(explicit)
        if not p.exists():
            sys.exit(f"lamina binary '{p}' does not exist")
        return p
    if build:
        print("building lamina (cargo build --release -p lamina-cli) ...", file=sys.stderr)
        r = subprocess.run(["cargo", "build", "--release", "-p", "lamina-cli"], cwd=REPO_DIR)
        if r.returncode != 0:
            sys.exit("cargo build failed; pass --lamina PATH to use an existing binary")
    p = REPO_DIR / "target" / "release" / "lamina"
    if not p.exists():
        sys.exit(f"no lamina binary at {p}")
    return p


def run_lamina(binary, scene, outputs, spp, threads, seed):
    """Runs `lamina render` and returns (wall seconds, parsed summary dict or None, stderr)."""
    cmd = [str(binary), "render", str(scene), "--spp", str(spp), "--threads", str(threads),
           "--seed", str(seed), "--quiet"]
    for o in outputs:
        cmd += ["-o", str(o)]
    t0 = time.perf_counter()
    r = subprocess.run(cmd, capture_output=True, text=True)
    wall = time.perf_counter() - t0
    if r.returncode != 0:
        sys.exit(f"lamina failed ({r.returncode}):\n{' '.join(cmd)}\n{r.stderr}")
    m = SUMMARY_RE.search(r.stderr)
    summary = None
    if m:
        summary = {"secs": float(m.group(4)), "setup": float(m.group(5) or 0.0),
                   "msamples": float(m.group(6)), "mrays": float(m.group(7))}
    return wall, summary, r.stderr.strip()


LIGHT_SAMPLING = ("all", "one")
SKY_SAMPLING = ("auto", "light", "bsdf")
LIGHT_SAMPLING_DEFAULT = "all,all:light,one:light"
LIGHT_SAMPLING_HELP = ("lamina modes to time, comma list of LIGHT[:SKY]: [integrator] light_sampling "
                       "(all: a shadow ray to every light per vertex; one: one light per vertex, as "
                       "Mitsuba does) and sky_sampling (auto, the default: the constant sky is left "
                       "to BSDF samples; light: also light-sampled, as Mitsuba does; bsdf)")


def light_sampling_modes(text):
    """`--light-sampling` of the comparison scripts: a comma list of modes `LIGHT[:SKY]`,
    lamina's `[integrator] light_sampling` (all: a shadow ray to every light per vertex;
    one: one light per vertex drawn by power, as Mitsuba's path integrators sample one
    emitter) and optionally its `sky_sampling` (auto, the default: a constant sky is left
    to BSDF samples; light: next-event estimation samples the sky too, as Mitsuba does;
    bsdf)."""
    modes = [m.strip() for m in text.split(",") if m.strip()]

    def ok(m):
        light, _, sky = m.partition(":")
        return light in LIGHT_SAMPLING and (":" not in m or sky in SKY_SAMPLING)

    bad = [m for m in modes if not ok(m)]
    if not modes or bad:
        raise SystemExit(f"--light-sampling: {text!r} is not a comma list of LIGHT[:SKY], "
                         f"LIGHT one of {', '.join(LIGHT_SAMPLING)}, SKY one of {', '.join(SKY_SAMPLING)}")
    return modes


def with_light_sampling(scene_toml, mode):
    """A copy of lamina scene `scene_toml` (beside it, `NAME_MODE.toml`) whose path
    integrator samples lights by `mode` (`LIGHT[:SKY]`, see `light_sampling_modes`); the
    file itself for "all" (the defaults)."""
    if mode == "all":
        return scene_toml
    light, _, sky = mode.partition(":")
    text = scene_toml.read_text()
    if "\n[integrator]\n" not in "\n" + text or "light_sampling" in text or "sky_sampling" in text:
        raise SystemExit(f"{scene_toml}: expected an [integrator] table without light_sampling "
                         "and sky_sampling")
    keys = f'light_sampling = "{light}"\n' + (f'sky_sampling = "{sky}"\n' if sky else "")
    text = ("\n" + text).replace("\n[integrator]\n", f"\n[integrator]\n{keys}", 1)[1:]
    out = scene_toml.with_name(f"{scene_toml.stem}_{mode_tag(mode)}.toml")
    out.write_text(text)
    return out


def mode_tag(mode):
    """`mode` in a file name (`one:light` -> `one_light`)."""
    return mode.replace(":", "_")


def run_lamina_mode(binary, scene_toml, out, mode, seed, spp, threads):
    """Renders `scene_toml` with light sampling `mode` (see `with_light_sampling`) and
    `seed` into `out/lamina[_MODE]_sSEED.{exr,png}`, prints its timing line, and returns
    (image, wall seconds, summary dict or None)."""
    tag = "" if mode == "all" else f"_{mode_tag(mode)}"
    exr = out / f"lamina{tag}_s{seed}.exr"
    wall, summ, err = run_lamina(binary, with_light_sampling(scene_toml, mode),
                                 [exr, out / f"lamina{tag}_s{seed}.png"], spp, threads, seed)
    line = next((l for l in err.splitlines() if "samples/s" in l), err)
    print(f"lamina light_sampling={mode} seed {seed}: {wall:.2f} s wall; {line}", flush=True)
    return load_exr(exr), wall, summ


def compile_running():
    """Whether some rustc is running (someone compiling on this machine)."""
    r = subprocess.run(["pgrep", "-x", "rustc"], capture_output=True, text=True)
    return bool(r.stdout.strip())


def cpu_info():
    model = "unknown"
    try:
        for line in open("/proc/cpuinfo"):
            if line.startswith("model name"):
                model = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    return model, os.cpu_count()


# ---------------------------------------------------------------- images

def load_exr(path):
    """An EXR as an HxWx3 float tensor (alpha dropped)."""
    bmp = mi.Bitmap(str(path))
    bmp = bmp.convert(mi.Bitmap.PixelFormat.RGB, mi.Struct.Type.Float32, srgb_gamma=False)
    return mi.TensorXf(bmp)


def _scalar(x):
    dr.eval(x)
    return float(x.array[0]) if hasattr(x, "array") else float(x[0])


def image_mean(img):
    return _scalar(dr.mean(img.array))


def compare(a, b, eps_frac=0.05):
    """Statistics of image `a` against reference `b` (both HxWx3):
    * mean_rel: mean over pixels and channels of |a - b| / max(b, eps),
      eps = eps_frac x (mean of b), so near-black pixels do not dominate;
    * mean_a, mean_b, means_rel: (mean a - mean b) / mean b;
    * rmse: sqrt(mean (a - b)^2), and rmse_rel = rmse / mean b."""
    mb = image_mean(b)
    ma = image_mean(a)
    eps = eps_frac * mb
    rel = dr.abs(a.array - b.array) / dr.maximum(b.array, eps)
    mean_rel = _scalar(dr.mean(rel))
    rmse = _scalar(dr.sqrt(dr.mean(dr.square(a.array - b.array))))
    return {"mean_rel": mean_rel, "mean_a": ma, "mean_b": mb, "means_rel": (ma - mb) / mb,
            "rmse": rmse, "rmse_rel": rmse / mb}


def equal_error_ratio(secs_a, pair_a, secs_b, pair_b):
    """Renderer a's time relative to the time renderer b needs to reach a's error (below 1:
    a is faster at equal error). `pair_a` / `pair_b`: two runs of each at the same spp with
    different seeds (their RMSE is sqrt(2) x one image's error, the same factor on both
    sides). It is the ratio of time x mean squared error at this spp: b's spp rescaled to
    a's error on the Monte Carlo rate (error^2 ~ 1 / spp) with b's time proportional to its
    spp, exact where b samples independently; where b's sampler converges faster than that,
    the ratio favours a. Returns (ratio, rmse_a, rmse_b)."""
    ea = compare(pair_a[0], pair_a[1])["rmse"]
    eb = compare(pair_b[0], pair_b[1])["rmse"]
    return secs_a * ea * ea / (secs_b * eb * eb), ea, eb


EQUAL_ERROR_NOTE = ("time x squared seed-to-seed RMSE at equal spp: Mitsuba's spp scaled to "
                    "lamina's error at error^2 ~ 1/spp, exact for Mitsuba's independent sampler; "
                    "a low-discrepancy Mitsuba sampler converges faster, so there it favours lamina")


def estimate_shift(a, b):
    """Sub-pixel offset (dx right, dy down, in pixels) of image `a` relative to `b`, by least
    squares on a - b = -(dx, dy) . grad b (central differences). Near 0 when the cameras and
    pixel grids agree; a half-pixel convention mismatch would give about 0.5."""
    d = (a - b)[1:-1, 1:-1, :]
    gx = (b[1:-1, 2:, :] - b[1:-1, :-2, :]) * 0.5
    gy = (b[2:, 1:-1, :] - b[:-2, 1:-1, :]) * 0.5
    s = lambda t: _scalar(dr.sum(t.array))
    return -s(d * gx) / s(gx * gx), -s(d * gy) / s(gy * gy)


def flip_x(img):
    return img[:, ::-1, :]


def side_by_side_png(images, path, exposure=0.0):
    """Writes images (HxWx3 linear tensors) next to each other as an sRGB PNG (clamped)."""
    scale = 2.0 ** exposure
    row = dr.concat([dr.clip(im * scale, 0.0, 1.0) for im in images], axis=1)
    bmp = mi.Bitmap(row, mi.Bitmap.PixelFormat.RGB)
    bmp = bmp.convert(mi.Bitmap.PixelFormat.RGB, mi.Struct.Type.UInt8, srgb_gamma=True)
    bmp.write(str(path))


def fmt_table(rows, header):
    widths = [max(len(str(r[i])) for r in [header] + rows) for i in range(len(header))]
    line = lambda r: "| " + " | ".join(str(c).ljust(w) for c, w in zip(r, widths)) + " |"
    sep = "|" + "|".join("-" * (w + 2) for w in widths) + "|"
    return "\n".join([line(header), sep] + [line(r) for r in rows])
