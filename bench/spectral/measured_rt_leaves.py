#!/usr/bin/env python3
"""Real leaves measured in reflectance AND transmittance, for `lamina leaf fit`, and the best
fit PROSPECT-D itself reaches on them (an independent reference for the fit's errors).

Usage:
    python3 bench/spectral/measured_rt_leaves.py --rda leaves.spct.rda -o /tmp/rt_leaves [--force]
    python3 bench/spectral/measured_rt_leaves.py --rda leaves.spct.rda -o DIR \
        --lamina target/release/lamina --prospect-fit

Where the data come from
------------------------
`data/leaves.spct.rda` of the R package photobiologyPlants (P. J. Aphalo; GitHub
aphalo/photobiologyPlants, also on CRAN): `Betula_ermanii.mspct` and `Solidago_altissima.mspct`,
total reflectance and total transmittance at 1 nm over 350-1000 nm of single leaves lit on the
adaxial or abaxial side, from Noda H., "Reflectance and transmittance spectra of leaves and
shoots of 22 vascular plant species ...", JaLTER ERDP-2013-02.1.1. The file is read with the
Python package `rdata` (`pip install rdata`); nothing of it is copied into this repository.
The adaxial spectra (what PROSPECT describes) are written as `NAME.csv` with the columns
`wavelength_nm,reflectance,transmittance` over 400-1000 nm.

With `--lamina`, each is fitted (`lamina leaf fit --spectrum CSV -o DIR/NAME`, flags after
`--` go to it) and its RMSE and band means printed. With `--prospect-fit` (`pip install
prosail==2.0.5 scipy`), PROSPECT-D alone is fitted to the same data with the same kind of
objective (per-nanometre R and T residuals plus 8 x the band means' errors, N, the five
pigments, water, dry matter and alpha free, three starts): where PROSPECT's own best fit
misses a band mean, the leaf model cannot do better than PROSPECT there.
"""

import argparse
import subprocess
import sys
import warnings
from pathlib import Path

BANDS = [(450, 500), (500, 570), (620, 700), (800, 900)]


def extract(rda, out, force):
    try:
        import rdata
    except ImportError:
        sys.exit("needs the Python package rdata: pip install rdata")
    warnings.filterwarnings("ignore")
    try:
        data = rdata.conversion.convert(rdata.parser.parse_file(rda))
    except Exception as e:  # noqa: BLE001 - any parse failure is the same error to the user
        sys.exit(f"{rda}: not a readable .rda file ({e})")
    written = []
    for collection in ("Betula_ermanii.mspct", "Solidago_altissima.mspct"):
        if collection not in data:
            sys.exit(f"{rda}: no {collection} in it (is it photobiologyPlants' data/leaves.spct.rda?)")
        for name, df in data[collection].items():
            if not str(name).endswith("adax"):
                continue
            path = out / f"{collection.split('.')[0]}_{name}.csv"
            if path.exists() and not force:
                sys.exit(f"{path} exists; give --force to replace it (or another -o folder)")
            tmp = path.with_suffix(".csv.tmp")
            with open(tmp, "w") as f:
                f.write("wavelength_nm,reflectance,transmittance\n")
                for w, r, t in zip(df["w.length"], df["Rfr"], df["Tfr"]):
                    if w >= 400:
                        f.write(f"{w},{r},{t}\n")
            tmp.replace(path)
            written.append(path)
    return written


def prospect_fit(path):
    import numpy as np
    import prosail
    from scipy.optimize import least_squares

    d = np.loadtxt(path, delimiter=",", skiprows=1)
    wl, R, T = d[:, 0], d[:, 1], d[:, 2]
    idx = np.rint(wl - 400).astype(int)

    def model(x):
        n, cab, car, anth, cbrown, cw, cm, alpha = x
        _, r, t = prosail.run_prospect(n, cab, car, cbrown, cw, cm, ant=anth,
                                       prospect_version="D", alpha=alpha)
        return r[idx], t[idx]

    def residuals(x):
        r, t = model(x)
        out = [r - R, t - T]
        for lo, hi in BANDS:
            m = (wl >= lo) & (wl < hi)
            k = 8 * np.sqrt(m.sum())
            out.append(np.array([k * (r[m].mean() - R[m].mean()), k * (t[m].mean() - T[m].mean())]))
        return np.concatenate(out)

    lo = [1, 0, 0, 0, 0, 0, 0, 10]
    hi = [3.5, 120, 40, 40, 2, 0.08, 0.05, 90]
    starts = [[1.5, 30, 8, 2, 0.1, 0.01, 0.005, 40], [1.2, 40, 10, 1, 0.01, 0.015, 0.008, 60],
              [2.0, 20, 5, 5, 0.2, 0.005, 0.002, 20]]
    best = min((least_squares(residuals, x0, bounds=(lo, hi)) for x0 in starts),
               key=lambda s: s.cost)
    r, t = model(best.x)
    rmse = (np.sqrt(np.mean((r - R) ** 2)), np.sqrt(np.mean((t - T) ** 2)))
    bands = []
    for lo_nm, hi_nm in BANDS:
        m = (wl >= lo_nm) & (wl < hi_nm)
        bands.append((r[m].mean() - R[m].mean(), t[m].mean() - T[m].mean()))
    return best.x, rmse, bands


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--rda", required=True, help="photobiologyPlants' data/leaves.spct.rda")
    ap.add_argument("-o", "--out", required=True, help="folder for the CSVs (and the fits)")
    ap.add_argument("--lamina", help="fit each with this lamina binary")
    ap.add_argument("--prospect-fit", action="store_true", help="PROSPECT-D's own best fit")
    ap.add_argument("--force", action="store_true",
                    help="replace CSVs (and fit folders) of the same names in --out")
    ap.add_argument("fit_flags", nargs="*", help="after --: flags for lamina leaf fit")
    args = ap.parse_args()
    rda = Path(args.rda)
    if not rda.is_file():
        sys.exit(f"{rda}: no such file")
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    for path in extract(rda, out, args.force):
        print(f"== {path.stem}")
        if args.lamina:
            force = ["--force"] if args.force else []
            r = subprocess.run([args.lamina, "leaf", "fit", "--spectrum", str(path), "-o",
                                str(out / path.stem), *force, *args.fit_flags],
                               capture_output=True, text=True)
            if r.returncode != 0:
                sys.exit(f"lamina leaf fit failed on {path}:\n{r.stderr}")
            for line in (r.stdout + r.stderr).splitlines():
                if "RMSE" in line or line.startswith("    ") and "nm" in line:
                    print("  lamina  " + line.strip())
        if args.prospect_fit:
            x, (rr, rt), bands = prospect_fit(path)
            print(f"  PROSPECT-D best fit: N={x[0]:.2f} cab={x[1]:.1f} car={x[2]:.1f} "
                  f"anth={x[3]:.1f} cbrown={x[4]:.2f} cw={x[5]:.4f} cm={x[6]:.4f} alpha={x[7]:.0f}")
            print(f"    RMSE R {rr:.4f}  T {rt:.4f}; band means (R, T) error: " + ", ".join(
                f"{lo}-{hi} nm {br:+.4f} {bt:+.4f}" for (lo, hi), (br, bt) in zip(BANDS, bands)))


if __name__ == "__main__":
    main()
