#!/usr/bin/env python3
"""Does a RAMI result depend on the size of the periodic cell? (issue 15, point 3)

Renders one case with cells of several sizes (each a different random placement of the same
LAI and leaf normals) and compares each cell's BRF (both planes) and fluxes with the largest
cell's: the RMS and mean of the differences against their combined standard errors (a z-score
RMS near 1 means no dependence beyond the Monte Carlo noise and the placement's own spread).

    python3 bench/rami_cell.py --case HOM11 --band nir --cells 2.5,5,10,20
"""

import argparse
import math
import subprocess
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import common  # noqa: E402
from common import read_rows  # noqa: E402


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--case", default="HOM11")
    ap.add_argument("--band", default="nir")
    ap.add_argument("--cells", default="2.5,5,10,20")
    ap.add_argument("--samples", type=int, default=16384)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--lamina", default=None)
    ap.add_argument("--no-build", action="store_true")
    ap.add_argument("--out", default=str(common.DEFAULT_OUT / "rami_cell"))
    a = ap.parse_args()
    out = Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    lamina = common.lamina_binary(a.lamina, build=not a.no_build)
    res = {}
    for c in [float(x) for x in a.cells.split(",")]:
        d = out / f"cell{c}"
        subprocess.run([str(lamina), "canopy", "rami", "--case", a.case, "--band", a.band,
                        "--cell", str(c), "--brf-samples", str(a.samples), "-o", str(d), "--force"],
                       check=True, capture_output=True)
        subprocess.run([str(lamina), "render", str(d / "scene.toml"), "--threads", str(a.threads),
                        "--quiet"], check=True, capture_output=True)
        rows = read_rows(d / "brfpp.csv") + read_rows(d / "brfop.csv")
        brf = np.array([float(x["brf"]) for x in rows])
        std = np.array([float(x["std"]) for x in rows])
        fl = {x["measure"]: (float(x["value"]), float(x["std"])) for x in read_rows(d / "fluxes.csv")}
        res[c] = (brf, std, fl)
    ref_c = max(res)
    rb, rs, rf = res[ref_c]
    print(f"{a.case} {a.band}: each cell against the {ref_c} m cell")
    print("cell_m  brf_rms_diff  brf_mean_diff  z_rms   albedo   ftran    fabs")
    for c, (b, s, f) in sorted(res.items()):
        d = b - rb
        z = d / np.sqrt(s ** 2 + rs ** 2)
        print(f"{c:6.1f}  {math.sqrt(np.mean(d ** 2)):.4f}        {d.mean():+.4f}        "
              f"{math.sqrt(np.mean(z ** 2)) if c != ref_c else 0:5.2f}   {f['albedo'][0]:.4f}   "
              f"{f['ftran'][0]:.4f}   {f['fabs'][0]:.4f}")


if __name__ == "__main__":
    main()
