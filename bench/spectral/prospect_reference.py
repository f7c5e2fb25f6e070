#!/usr/bin/env python3
"""Reference PROSPECT spectra from an independent implementation, for lamina-leaf's tests.

Usage: pip install prosail==2.0.5 && python3 bench/spectral/prospect_reference.py

Runs the `prosail` package's PROSPECT-D (J. Gomez-Dans, PyPI `prosail` 2.0.5) for a few leaves
and writes crates/lamina-leaf/tests/data/prospect_reference.tsv, which
`crates/lamina-leaf/tests/prospect.rs` compares with lamina's own PROSPECT at every wavelength
(400-2500 nm, 1 nm; bar 0.002 absolute).

PROSPECT-PRO: `prosail` has no PRO switch, but its plate model takes the specific absorption
coefficients as arguments, and PRO differs from D only in the dry-matter term
(cm * k_m  ->  prot * k_prot + cbc * k_cbc, with LMA = prot + cbc). So the PRO cases call the
same prosail code with k_m replaced by (prot k_prot + cbc k_cbc) and cm = 1, the PRO constants
read from ../shared/data/prospect/dataSpec_PRO.txt (same nr, k_ab, ... as prosail's own table,
checked below).

Values are written as integers in units of 1e-5 (R, T), one row per wavelength.
"""
from pathlib import Path
import numpy as np
import prosail

ROOT = Path(__file__).resolve().parents[2]
OUT = ROOT / "crates/lamina-leaf/tests/data/prospect_reference.tsv"
SPEC = ROOT.parent / "shared/data/prospect/dataSpec_PRO.txt"

# name, model, N, cab, car, anth, cbrown, cw, cm, prot, cbc, alpha (PROSPECT's surface cone, deg)
CASES = [
    ("green", "d", 1.5, 40.0, 8.0, 0.0, 0.0, 0.010, 0.009, 0.0, 0.0, 40.0),
    ("dark_red", "d", 2.2, 70.0, 15.0, 10.0, 0.5, 0.020, 0.012, 0.0, 0.0, 40.0),
    ("thin_pale", "d", 1.0, 5.0, 1.0, 2.0, 0.0, 0.002, 0.002, 0.0, 0.0, 40.0),
    ("pro", "pro", 1.8, 45.0, 10.0, 1.0, 0.1, 0.015, 0.0, 0.001, 0.009, 40.0),
    ("hairy", "d", 1.7, 35.0, 9.0, 1.0, 0.0, 0.012, 0.006, 0.0, 0.0, 70.0),
]

spec = np.loadtxt(SPEC, skiprows=1)
lib = prosail.spectral_lib.prospectd
for ours, theirs in zip(spec.T[1:8], [lib.nr, lib.kab, lib.kcar, lib.kant, lib.kbrown, lib.kw, lib.km]):
    assert np.array_equal(ours, theirs), "prosail's PROSPECT-D table differs from dataSpec_PRO"
kprot, kcbc = spec[:, 8], spec[:, 9]

columns = []
header = ["wavelength_nm"]
for name, model, n, cab, car, anth, cbrown, cw, cm, prot, cbc, alpha in CASES:
    if model == "d":
        wl, r, t = prosail.run_prospect(n, cab, car, cbrown, cw, cm, ant=anth,
                                        prospect_version="D", alpha=alpha)
    else:
        km = prot * kprot + cbc * kcbc
        wl, r, t = prosail.run_prospect(n, cab, car, cbrown, cw, 1.0, ant=anth,
                                        prospect_version="D", km=km, alpha=alpha)
    columns += [np.rint(r * 1e5).astype(int), np.rint(t * 1e5).astype(int)]
    header += [f"{name}_r", f"{name}_t"]

lines = ["# PROSPECT reference from prosail 2.0.5 (bench/spectral/prospect_reference.py); R, T in 1e-5.",
         "# cases: name model N cab car anth cbrown cw cm prot cbc alpha"]
for c in CASES:
    lines.append("# case " + " ".join(str(x) for x in c))
lines.append("\t".join(header))
for i, w in enumerate(wl):
    lines.append("\t".join([str(int(w))] + [str(col[i]) for col in columns]))
OUT.write_text("\n".join(lines) + "\n")
print(f"wrote {OUT} ({OUT.stat().st_size} bytes)")
