#!/usr/bin/env python3
"""RAMI canopies in lamina and in Mitsuba 3, side by side (issue 15).

For each band, `lamina canopy rami` writes the scene folder; `lamina render` measures the BRF
in the principal and orthogonal planes (76 view directions each) and the flux budget through
the periodic cell. Mitsuba 3 (`llvm_ad_rgb`) renders the same leaves (the same 32-gon discs,
placements read from leaves.csv), bi-Lambertian through bench/common.py's `lamina_difftrans`
BSDF, over the same soil under the same parallel sun. Mitsuba has no periodic boundary, so its
canopy is the cell tiled `--tiles` x `--tiles` times (default 5: 2 cells of margin around the
centre one) and it measures over the centre cell:

* BRF: one `distant` sensor per view direction aimed at the centre cell's top (a `batch`
  sensor renders all 76 of a plane in one pass), `--batches` independent seeds give the
  standard error;
* fluxes: `irradiancemeter`s on null-BSDF rectangles over the centre cell: facing down just
  above the canopy (albedo = upwelling / E), facing up just above the soil (ftran =
  downwelling at the soil / E), fabs = 1 - albedo - ftran (1 - soil) (volpath, which passes
  through null surfaces).

Reports per band: z-scores (difference / combined standard error) over the 152 directions,
the flux rows with both errors, both times; writes out/rami_compare/<case>_<band>.png (both
renderers' BRFs with error bars) and summary.csv.

    python3 bench/rami_compare.py --case HOM11 --bands red,nir,nr1 --samples 16384
    python3 bench/rami_compare.py --target-error 0.001     # the speed comparison (issue 15, point 6)
"""

import argparse
import math
import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import common  # noqa: E402
from common import read_rows  # noqa: E402

SOIL = {"red": 0.127, "nir": 0.159, "nr1": 1.0}


def disc_vertices(obj_path):
    verts, faces = [], []
    for line in open(obj_path):
        p = line.split()
        if not p:
            continue
        if p[0] == "v":
            verts.append([float(x) for x in p[1:4]])
        elif p[0] == "f":
            faces.append([int(x) - 1 for x in p[1:4]])
    return np.array(verts, dtype=np.float64), np.array(faces, dtype=np.int64)


def leaves_mesh(folder, tiles, cell):
    """All discs of the tiled canopy: vertices (N, 3) and faces (M, 3), lamina's transform
    order (rotate about x, then y, then translate)."""
    v0, f0 = disc_vertices(folder / "disc.obj")
    data = np.loadtxt(folder / "leaves.csv", delimiter=",", skiprows=2)
    t, rx, ry = data[:, 0:3], np.radians(data[:, 3]), np.radians(data[:, 4])
    cx, sx, cy, sy = np.cos(rx), np.sin(rx), np.cos(ry), np.sin(ry)
    # R = Ry(ry) Rx(rx), per leaf.
    n = len(data)
    rot = np.zeros((n, 3, 3))
    rot[:, 0, 0] = cy
    rot[:, 0, 1] = sy * sx
    rot[:, 0, 2] = sy * cx
    rot[:, 1, 1] = cx
    rot[:, 1, 2] = -sx
    rot[:, 2, 0] = -sy
    rot[:, 2, 1] = cy * sx
    rot[:, 2, 2] = cy * cx
    one = np.einsum("nij,vj->nvi", rot, v0) + t[:, None, :]  # (n, V, 3)
    shifts = [(i * cell, j * cell) for i in range(-(tiles // 2), tiles // 2 + 1)
              for j in range(-(tiles // 2), tiles // 2 + 1)]
    verts, faces = [], []
    nv = len(v0)
    for k, (dx, dz) in enumerate(shifts):
        v = one.copy()
        v[:, :, 0] += dx
        v[:, :, 2] += dz
        verts.append(v.reshape(-1, 3))
        base = (k * n + np.arange(n))[:, None, None] * nv
        faces.append((f0[None, :, :] + base).reshape(-1, 3))
    return np.concatenate(verts).astype(np.float32), np.concatenate(faces).astype(np.int32)


def write_ply(path, verts, faces):
    with open(path, "wb") as f:
        f.write(("ply\nformat binary_little_endian 1.0\n"
                 f"element vertex {len(verts)}\nproperty float x\nproperty float y\nproperty float z\n"
                 f"element face {len(faces)}\nproperty list uchar int vertex_indices\nend_header\n")
                .encode())
        f.write(verts.astype("<f4").tobytes())
        rec = np.zeros(len(faces), dtype=[("n", "u1"), ("i", "<i4", (3,))])
        rec["n"] = 3
        rec["i"] = faces
        f.write(rec.tobytes())


def rect(mi, centre, half, normal_up):
    """A rectangle in the x-z plane at `centre`, half-size `half`, normal +y or -y."""
    T = mi.ScalarTransform4f
    rot = T().rotate([1, 0, 0], -90 if normal_up else 90)
    return T().translate(centre) @ rot @ T().scale([half, half, 1])


def mitsuba_scene(mi, ply, band, sza, cell, tiles, top):
    r, t = {"red": (0.0546, 0.0149), "nir": (0.4957, 0.4409), "nr1": (0.5, 0.5)}[band]
    span = tiles * cell
    lo = -(tiles // 2) * cell
    s = math.radians(sza)
    return {
        "type": "scene",
        "leaves": {"type": "ply", "filename": str(ply),
                   "bsdf": {"type": "lamina_difftrans", "reflectance": common.rgb(r),
                            "transmittance": common.rgb(t)}},
        "soil": {"type": "rectangle",
                 "to_world": rect(mi, [lo + span / 2, 0, lo + span / 2], span / 2, True),
                 "bsdf": {"type": "diffuse", "reflectance": common.rgb(SOIL[band])}},
        "sun": {"type": "directional", "direction": [-math.sin(s), -math.cos(s), 0],
                "irradiance": common.rgb(1.0)},
    }


def view_dir(zenith, rel_az, sun_az=90.0):
    # lamina: azimuth atan2(x, z); the RAMI scenes put the sun in the x-y plane (azimuth 90).
    th, ph = math.radians(zenith), math.radians(sun_az + rel_az)
    return [math.sin(th) * math.sin(ph), math.cos(th), math.sin(th) * math.cos(ph)]


def mitsuba_brf(mi, dr, base, directions, cell, top, spp, batches, max_depth, e):
    sensors = {}
    for k, (z, az) in enumerate(directions):
        v = view_dir(z, az)
        sensors[f"s{k:03d}"] = {
            "type": "distant", "direction": [-v[0], -v[1], -v[2]],
            "target": {"type": "rectangle",
                       "to_world": rect(mi, [cell / 2, top, cell / 2], cell / 2, True)},
            "film": {"type": "hdrfilm", "width": 1, "height": 1, "rfilter": {"type": "box"},
                     "pixel_format": "rgb"},
        }
    scene = dict(base)
    scene["integrator"] = {"type": "path", "max_depth": max_depth + 1, "rr_depth": 9}
    scene["sensor"] = {"type": "batch", **sensors,
                       "sampler": {"type": "independent", "sample_count": spp},
                       "film": {"type": "hdrfilm", "width": len(directions), "height": 1,
                                "rfilter": {"type": "box"}, "pixel_format": "rgb"}}
    sc = mi.load_dict(scene)
    per = max(1, spp // batches)
    means = []
    t0 = time.perf_counter()
    for b in range(batches):
        img = mi.render(sc, spp=per, seed=dr.opaque(mi.UInt32, 1000 + b))
        means.append(np.array(img)[0, :, 0])
    secs = time.perf_counter() - t0
    m = np.array(means)
    k = math.pi / e
    return m.mean(0) * k, m.std(0, ddof=1) / math.sqrt(batches) * k, secs


def mitsuba_fluxes(mi, dr, base, cell, top, spp, batches, max_depth):
    """Upwelling irradiance above the canopy (an irradiancemeter facing down), and the
    radiance of the soil over the centre cell (an orthographic camera 2 mm above it): an
    irradiancemeter cannot see a parallel sun, so the soil's radiance ρ E↓ / π stands in for
    the downwelling irradiance at the soil."""
    out = {}
    secs = 0.0
    scene = dict(base)
    scene["integrator"] = {"type": "path", "max_depth": max_depth + 1, "rr_depth": 9}
    res = 32
    T = mi.ScalarTransform4f
    scene["sensor"] = {
        "type": "orthographic", "near_clip": 1e-4, "far_clip": 1.0,
        "to_world": T().look_at(origin=[cell / 2, 0.002, cell / 2], target=[cell / 2, 0, cell / 2],
                                up=[0, 0, 1]) @ T().scale([cell / 2, cell / 2, 1]),
        "sampler": {"type": "independent", "sample_count": max(1, spp // (res * res))},
        "film": {"type": "hdrfilm", "width": res, "height": res, "rfilter": {"type": "box"},
                 "pixel_format": "rgb"}}
    sc = mi.load_dict(scene)
    per = max(1, spp // (res * res) // batches)
    vals = []
    t0 = time.perf_counter()
    for b in range(batches):
        img = mi.render(sc, spp=per, seed=dr.opaque(mi.UInt32, 3000 + b))
        vals.append(float(np.array(img)[:, :, 0].mean()))
    secs += time.perf_counter() - t0
    v = np.array(vals)
    out["soil_radiance"] = (v.mean(), v.std(ddof=1) / math.sqrt(batches))
    for name, y, up in (("up", top, False),):
        scene = dict(base)
        scene["integrator"] = {"type": "volpath", "max_depth": max_depth + 1, "rr_depth": 9}
        scene["meter"] = {"type": "rectangle",
                          "to_world": rect(mi, [cell / 2, y, cell / 2], cell / 2, up),
                          "bsdf": {"type": "null"},
                          "sensor": {"type": "irradiancemeter",
                                     "sampler": {"type": "independent", "sample_count": spp},
                                     "film": {"type": "hdrfilm", "width": 1, "height": 1,
                                              "rfilter": {"type": "box"},
                                              "pixel_format": "rgb"}}}
        sc = mi.load_dict(scene)
        per = max(1, spp // batches)
        vals = []
        t0 = time.perf_counter()
        for b in range(batches):
            img = mi.render(sc, spp=per, seed=dr.opaque(mi.UInt32, 2000 + b))
            vals.append(float(np.array(img).ravel()[0]))
        secs += time.perf_counter() - t0
        v = np.array(vals)
        out[name] = (v.mean(), v.std(ddof=1) / math.sqrt(batches))
    return out, secs


def plot(path, title, curves):
    """curves: list of (label, colour, xs, ys, errs)."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, axes = plt.subplots(1, 2, figsize=(12, 4.5), sharey=True)
    for ax, plane in zip(axes, ("principal", "orthogonal")):
        for label, colour, xs, ys, es, pl in curves:
            if pl != plane:
                continue
            ax.errorbar(xs, ys, yerr=2 * np.asarray(es), label=label, color=colour, capsize=2,
                        lw=1.2, elinewidth=0.8)
        ax.set_title(f"{plane} plane")
        ax.set_xlabel("view zenith (degrees; negative: the other half-plane)")
        ax.grid(alpha=0.3)
    axes[0].set_ylabel("BRF (bars: ±2 standard errors)")
    axes[0].legend()
    fig.suptitle(title)
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--case", default="HOM11")
    ap.add_argument("--lad", default="uni")
    ap.add_argument("--bands", default="red,nir,nr1")
    ap.add_argument("--sun-zenith", type=float, default=20.0)
    ap.add_argument("--cell", type=float, default=10.0)
    ap.add_argument("--tiles", type=int, default=5, help="Mitsuba's canopy: cells along each side")
    ap.add_argument("--samples", type=int, default=16384, help="rays per BRF direction, both")
    ap.add_argument("--photons", type=int, default=1_000_000, help="lamina's flux photons")
    ap.add_argument("--flux-spp", type=int, default=1 << 20, help="Mitsuba irradiancemeter samples")
    ap.add_argument("--batches", type=int, default=16, help="Mitsuba seeds per estimate")
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--target-error", type=float, default=None,
                    help="speed run: scale both renderers' BRF samples until the largest "
                         "standard error is below this, and time them")
    ap.add_argument("--lamina", default=None)
    ap.add_argument("--no-build", action="store_true")
    ap.add_argument("--out", default=str(common.DEFAULT_OUT / "rami_compare"))
    a = ap.parse_args()

    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    lamina = common.lamina_binary(a.lamina, build=not a.no_build)
    mi, dr = common.setup_mitsuba(a.threads)
    print(f"machine: {common.cpu_info()}, {a.threads} threads for each renderer")
    summary = ["case,band,renderer,brf_seconds,directions,max_std,mean_abs_z,max_abs_z,"
               "frac_abs_z_gt_2,albedo,albedo_std,ftran,ftran_std,fabs,fabs_std"]
    for band in a.bands.split(","):
        folder = out / f"{a.case}_{a.lad}_{band}"
        subprocess.run([str(lamina), "canopy", "rami", "--case", a.case, "--lad", a.lad,
                        "--band", band, "--sun-zenith", str(a.sun_zenith), "--cell", str(a.cell),
                        "--brf-samples", str(a.samples), "--photons", str(a.photons),
                        "-o", str(folder), "--force"], check=True, capture_output=True)
        t0 = time.perf_counter()
        r = subprocess.run([str(lamina), "render", str(folder / "scene.toml"), "--threads",
                            str(a.threads), "--quiet"], capture_output=True, text=True)
        lamina_total = time.perf_counter() - t0
        if r.returncode != 0:
            sys.exit(r.stderr)
        brf_s = [float(x.split("sensor 'brf': ")[1].split(" s")[0])
                 for x in r.stderr.splitlines() if "sensor 'brf': " in x][0]
        pp = read_rows(folder / "brfpp.csv")
        op = read_rows(folder / "brfop.csv")
        fl = {row["measure"]: (float(row["value"]), float(row["std"]))
              for row in read_rows(folder / "fluxes.csv")}
        # Mitsuba.
        top = max(float(l.split(",")[1]) for l in open(folder / "leaves.csv")
                  if l[0].isdigit()) + 0.06
        verts, faces = leaves_mesh(folder, a.tiles, a.cell)
        ply = out / f"{a.case}_{a.lad}_leaves_{a.tiles}.ply"
        write_ply(ply, verts, faces)
        base = mitsuba_scene(mi, ply, band, a.sun_zenith, a.cell, a.tiles, top)
        curves = []
        zs = []
        mi_secs = 0.0
        mi_max_std = 0.0
        for name, rows, colour in (("principal", pp, ("tab:red", "darkred")),
                                   ("orthogonal", op, ("tab:blue", "navy"))):
            dirs = [(float(x["vza"]), float(x["raa"])) for x in rows]
            signed = [float(x["vza"]) * (-1 if float(x["raa"]) >= 180 else 1) for x in rows]
            lv = np.array([float(x["brf"]) for x in rows])
            ls = np.array([float(x["std"]) for x in rows])
            mv, ms, secs = mitsuba_brf(mi, dr, base, dirs, a.cell, top, a.samples, a.batches, 1024,
                                       math.cos(math.radians(a.sun_zenith)))
            mi_secs += secs
            mi_max_std = max(mi_max_std, float(ms.max()))
            z = (lv - mv) / np.sqrt(ls ** 2 + ms ** 2)
            zs.extend(z.tolist())
            order = np.argsort(signed)
            xs = np.array(signed)[order]
            curves.append((f"lamina {name}", colour[0], xs, lv[order], ls[order], name))
            curves.append((f"Mitsuba {name}", colour[1], xs + 0.4, mv[order], ms[order], name))
        zs = np.array(zs)
        fx, fsecs = mitsuba_fluxes(mi, dr, base, a.cell, top, a.flux_spp, a.batches, 1024)
        e = math.cos(math.radians(a.sun_zenith))
        m_alb, m_alb_s = fx["up"][0] / e, fx["up"][1] / e
        rho = SOIL[band]
        m_ftr = fx["soil_radiance"][0] * math.pi / (rho * e)
        m_ftr_s = fx["soil_radiance"][1] * math.pi / (rho * e)
        m_fab = 1 - m_alb - m_ftr * (1 - SOIL[band])
        m_fab_s = math.hypot(m_alb_s, m_ftr_s * (1 - SOIL[band]))
        plot(out / f"{a.case}_{a.lad}_{band}.png",
             f"RAMI {a.case} {a.lad} {band}, sun zenith {a.sun_zenith}°: lamina (periodic) vs "
             f"Mitsuba 3 ({a.tiles}x{a.tiles} cells)", curves)
        print(f"\n{a.case} {a.lad} {band}: {len(zs)} directions, |z| mean {np.abs(zs).mean():.2f}, "
              f"max {np.abs(zs).max():.2f}, share |z| > 2: {np.mean(np.abs(zs) > 2):.3f} "
              f"(expected ~0.046 if they agree)")
        print(f"  BRF time: lamina {brf_s:.2f} s (whole render {lamina_total:.2f} s), "
              f"Mitsuba {mi_secs:.2f} s at {a.samples} rays per direction; largest std: "
              f"lamina {max(float(x['std']) for x in pp + op):.4f}, Mitsuba {mi_max_std:.4f}")
        for k, (lv_, ls_), (mv_, ms_) in (("albedo", fl["albedo"], (m_alb, m_alb_s)),
                                          ("ftran", fl["ftran"], (m_ftr, m_ftr_s)),
                                          ("fabs", fl["fabs"], (m_fab, m_fab_s))):
            z = (lv_ - mv_) / math.hypot(ls_, ms_) if math.hypot(ls_, ms_) > 0 else 0.0
            print(f"  {k:7s} lamina {lv_:.4f} ± {ls_:.4f}   Mitsuba {mv_:.4f} ± {ms_:.4f}   z {z:+.2f}")
        print(f"  Mitsuba flux time {fsecs:.2f} s ({a.flux_spp} samples per meter)")
        lamina_max = max(float(x["std"]) for x in pp + op)
        summary.append(
            f"{a.case},{band},lamina,{brf_s:.3f},{len(zs)},{lamina_max:.5f},{np.abs(zs).mean():.3f},"
            f"{np.abs(zs).max():.3f},{np.mean(np.abs(zs) > 2):.3f},{fl['albedo'][0]:.5f},"
            f"{fl['albedo'][1]:.5f},{fl['ftran'][0]:.5f},{fl['ftran'][1]:.5f},{fl['fabs'][0]:.5f},"
            f"{fl['fabs'][1]:.5f}")
        summary.append(
            f"{a.case},{band},mitsuba,{mi_secs:.3f},{len(zs)},{mi_max_std:.5f},,,,{m_alb:.5f},"
            f"{m_alb_s:.5f},{m_ftr:.5f},{m_ftr_s:.5f},{m_fab:.5f},{m_fab_s:.5f}")
        if a.target_error:
            # Samples each renderer needs for its largest standard error to reach the target
            # (error ∝ 1/√samples, from the run above), then both run at that count.
            need_l = math.ceil(a.samples * (lamina_max / a.target_error) ** 2)
            need_m = math.ceil(a.samples * (mi_max_std / a.target_error) ** 2)
            r = subprocess.run([str(lamina), "render", str(folder / "scene.toml"), "--threads",
                                str(a.threads), "--quiet", "--set", f"sensor[0].samples={need_l}",
                                "--set", "sensor[1].samples=32"], capture_output=True, text=True)
            if r.returncode != 0:
                sys.exit(r.stderr)
            tl = [float(x.split("sensor 'brf': ")[1].split(" s")[0])
                  for x in r.stderr.splitlines() if "sensor 'brf': " in x][0]
            got_l = max(float(x["std"]) for x in read_rows(folder / "brfpp.csv") + read_rows(folder / "brfop.csv"))
            tm, got_m = 0.0, 0.0
            for name, rows in (("principal", pp), ("orthogonal", op)):
                dirs = [(float(x["vza"]), float(x["raa"])) for x in rows]
                _, ms, secs = mitsuba_brf(mi, dr, base, dirs, a.cell, top, need_m, a.batches, 1024,
                                          math.cos(math.radians(a.sun_zenith)))
                tm += secs
                got_m = max(got_m, float(ms.max()))
            print(f"  to a standard error of {a.target_error}: lamina {need_l} rays per direction, "
                  f"{tl:.1f} s (largest std {got_l:.5f}); Mitsuba {need_m} rays, {tm:.1f} s "
                  f"(largest std {got_m:.5f}): Mitsuba / lamina = {tm / tl:.2f}")
            summary.append(f"{a.case},{band},lamina@{a.target_error},{tl:.3f},{len(zs)},{got_l:.5f},,,,,,,,,")
            summary.append(f"{a.case},{band},mitsuba@{a.target_error},{tm:.3f},{len(zs)},{got_m:.5f},,,,,,,,,")
        os.remove(ply)
    (out / "summary.csv").write_text("\n".join(summary) + "\n")
    print(f"\nwrote {out / 'summary.csv'} and the plots in {out}")


if __name__ == "__main__":
    main()
