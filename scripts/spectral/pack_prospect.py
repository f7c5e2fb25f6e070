#!/usr/bin/env python3
"""Packs the PROSPECT-PRO optical constants into lamina-leaf's compact embedded table.

Usage: scripts/spectral/pack_prospect.py [../shared/data/prospect/dataSpec_PRO.txt]

Writes crates/lamina-leaf/data/prospect/prospect_pro.tsv: the same 2101 rows (400-2500 nm,
1 nm) and nine constants, each written in the shortest decimal form that reads back to the
same double as the original text (so the table is lossless), without the wavelength column
(implied by the row). The constants are J.-B. Féret's (R package 'prospect', MIT licence,
LICENSE.md beside the output), from Féret et al. 2017 (PROSPECT-D) and 2021 (PROSPECT-PRO).
"""
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
src = Path(sys.argv[1]) if len(sys.argv) > 1 else ROOT.parent / "shared/data/prospect/dataSpec_PRO.txt"
out = ROOT / "crates/lamina-leaf/data/prospect/prospect_pro.tsv"

lines = src.read_text().splitlines()
header = lines[0].split()
assert header[0] == "lambda" and len(header) == 10, header
rows = []
for i, line in enumerate(lines[1:]):
    cells = line.split()
    assert len(cells) == 10 and int(cells[0]) == 400 + i, (i, line)
    rows.append([float(c) for c in cells[1:]])
assert len(rows) == 2101

def short(x: float) -> str:
    if x == 0.0:
        return "0"
    for digits in range(1, 18):
        s = f"{x:.{digits}g}"
        if float(s) == x:
            return s.replace("e-0", "e-").replace("e+0", "e")
    raise AssertionError(x)

text = ["# PROSPECT-PRO optical constants 400-2500 nm at 1 nm, one row per nm (no wavelength column).",
        "# Columns: " + " ".join(header[1:]),
        "# (c) 2020-present Jean-Baptiste Feret, MIT licence (LICENSE.md). Feret et al. 2017, RSE 193:204-215;",
        "# Feret et al. 2021, RSE 252:112173. Packed losslessly by scripts/spectral/pack_prospect.py."]
for r in rows:
    text.append(" ".join(short(x) for x in r))
out.write_text("\n".join(text) + "\n")
# Lossless check.
back = [[float(c) for c in l.split()] for l in out.read_text().splitlines() if not l.startswith("#")]
assert back == rows
print(f"wrote {out} ({out.stat().st_size} bytes, from {src.stat().st_size})")
