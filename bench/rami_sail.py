#!/usr/bin/env python3
"""lamina's discrete RAMI canopy against SAIL's turbid medium (issue 15, point 5).

At a fixed LAI, leaf normal distribution and optics, `lamina canopy rami --leaf-radius r`
makes ever smaller leaves (the cell shrinking with them, so that the number of leaves stays
about the same); `lamina render` measures the BRF in the principal and orthogonal planes.
SAIL (4SAIL as the `prosail` package on PyPI implements it: Verhoef's uniform leaf
inclination, `typelidf = 1, lidfa = 0, lidfb = 0`, the same leaf R, T and soil) gives the
turbid-medium BRF, with its hotspot parameter set to the leaves' size over the canopy
height (2 r / h). Away from the hotspot (|view zenith - sun zenith| > 10° in the principal
plane, and the whole orthogonal plane) lamina's BRF should approach SAIL's as r shrinks;
the hotspot itself is the discrete canopy's physics.

Writes out/rami_sail/brf.png (the curves) and out/rami_sail/convergence.csv (RMS and mean
difference away from the hotspot per radius) and prints them.

    pip install prosail matplotlib
    python3 bench/rami_sail.py --band nir --samples 8192
"""

import argparse
import math
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import common  # noqa: E402
from common import read_rows  # noqa: E402

BANDS = {"red": (0.0546, 0.0149, 0.127), "nir": (0.4957, 0.4409, 0.159)}
CASES = {"HOM11": (1.0, 1.0), "HOM12": (2.0, 1.0), "HOM13": (3.0, 2.0), "HOM15": (5.0, 1.0)}


def sail_brf(band, lai, h, r, sza, vza, raa):
    import prosail
    lr, lt, soil = BANDS[band]
    n = 2101
    out = prosail.run_sail(np.full(n, lr), np.full(n, lt), lai, 0.0, 2.0 * r / h, sza, vza, raa,
                           typelidf=1, lidfb=0.0, factor="SDR", rsoil0=np.full(n, soil))
    return float(np.asarray(out)[0])


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--case", default="HOM11", choices=sorted(CASES))
    ap.add_argument("--band", default="nir", choices=sorted(BANDS))
    ap.add_argument("--sun-zenith", type=float, default=20.0)
    ap.add_argument("--radii", default="0.05,0.025,0.0125,0.00625")
    ap.add_argument("--samples", type=int, default=8192)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--lamina", default=None)
    ap.add_argument("--no-build", action="store_true")
    ap.add_argument("--out", default=str(common.DEFAULT_OUT / "rami_sail"))
    a = ap.parse_args()
    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    lamina = common.lamina_binary(a.lamina, build=not a.no_build)
    lai, h = CASES[a.case]
    radii = [float(x) for x in a.radii.split(",")]
    results = {}
    for r in radii:
        cell = max(2.5, 10.0 * r / 0.05)
        folder = out / f"r{r}"
        subprocess.run([str(lamina), "canopy", "rami", "--case", a.case, "--band", a.band,
                        "--sun-zenith", str(a.sun_zenith), "--leaf-radius", str(r), "--cell",
                        str(cell), "--brf-samples", str(a.samples), "--photons", "100000",
                        "-o", str(folder), "--force"], check=True, capture_output=True)
        t0 = time.perf_counter()
        subprocess.run([str(lamina), "render", str(folder / "scene.toml"), "--threads",
                        str(a.threads), "--quiet"], check=True, capture_output=True)
        secs = time.perf_counter() - t0
        planes = {}
        for plane, f in (("principal", "brfpp.csv"), ("orthogonal", "brfop.csv")):
            rows = read_rows(folder / f)
            planes[plane] = [(float(x["vza"]), float(x["raa"]), float(x["brf"]), float(x["std"]))
                             for x in rows]
        results[r] = (cell, secs, planes)
        print(f"radius {r} m (cell {cell} m): rendered in {secs:.1f} s", file=sys.stderr)
    # SAIL per radius (its hotspot parameter follows the leaf size).
    lines = ["radius_m,cell_m,rms_away_from_hotspot,mean_diff_away,max_abs_diff_away,max_std"]
    curves = []
    print(f"\n{a.case} {a.band}, sun zenith {a.sun_zenith}°: lamina (discrete) - SAIL (turbid), "
          f"away from the hotspot")
    for r in radii:
        cell, secs, planes = results[r]
        diffs, stds = [], []
        for plane, rows in planes.items():
            xs, ls, ss = [], [], []
            for vza, raa, brf, std in rows:
                sail = sail_brf(a.band, lai, h, r, a.sun_zenith, vza, raa)
                signed = -vza if raa >= 180 else vza
                xs.append(signed)
                ls.append(brf)
                ss.append(sail)
                away = plane == "orthogonal" or abs(signed - a.sun_zenith) > 10
                if away:
                    diffs.append(brf - sail)
                    stds.append(std)
            order = np.argsort(xs)
            curves.append((r, plane, np.array(xs)[order], np.array(ls)[order], np.array(ss)[order]))
        d = np.array(diffs)
        rms = float(np.sqrt(np.mean(d ** 2)))
        lines.append(f"{r},{cell},{rms:.5f},{d.mean():.5f},{np.abs(d).max():.5f},{max(stds):.5f}")
        print(f"  r = {r:<8} RMS {rms:.4f}  mean {d.mean():+.4f}  max |d| {np.abs(d).max():.4f}  "
              f"(lamina's largest standard error {max(stds):.4f})")
    (out / "convergence.csv").write_text("\n".join(lines) + "\n")
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, axes = plt.subplots(1, 2, figsize=(12, 4.5), sharey=True)
    colours = plt.cm.viridis(np.linspace(0, 0.85, len(radii)))
    for ax, plane in zip(axes, ("principal", "orthogonal")):
        for (r, pl, xs, ls, ss), c in zip([x for x in curves if x[1] == plane], colours):
            ax.plot(xs, ls, color=c, lw=1.2, label=f"lamina r = {r} m")
            ax.plot(xs, ss, color=c, lw=1.0, ls="--", label=f"SAIL hspot = {2 * r / h:.4f}")
        ax.set_title(f"{plane} plane")
        ax.set_xlabel("view zenith (degrees)")
        ax.grid(alpha=0.3)
    axes[0].set_ylabel("BRF")
    axes[0].legend(fontsize=7)
    fig.suptitle(f"{a.case} {a.band}, sun zenith {a.sun_zenith}°: discrete discs (solid) vs SAIL (dashed)")
    fig.tight_layout()
    fig.savefig(out / "brf.png", dpi=90)
    print(f"\nwrote {out / 'brf.png'} and {out / 'convergence.csv'}")


if __name__ == "__main__":
    main()
