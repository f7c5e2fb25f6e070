#!/usr/bin/env python3
"""Prints the CIE daylight (D-series) basis functions S0, S1, S2 as the Rust constants in
lamina-sky's src/preetham.rs, 300..=830 nm every 10 nm.

Source: colour-science (tested with 0.4.7), `colour.colorimetry.datasets.illuminants.
sds_d_illuminant_series.SDS_BASIS_FUNCTIONS_CIE_ILLUMINANT_D_SERIES`, which tabulates the
CIE's functions (CIE 015, Table T.2; Wyszecki & Stiles, Color Science, 2000, pp. 145-146)
at 5 nm. Its 5 nm rows between the 10 nm ones are the midpoints of their neighbours (this
script checks it), so the 10 nm rows are the data and linear interpolation gives the rest.

Usage: pip install colour-science; python3 d_series_basis.py
"""

import numpy as np
from colour.colorimetry.datasets.illuminants.sds_d_illuminant_series import (
    SDS_BASIS_FUNCTIONS_CIE_ILLUMINANT_D_SERIES as BASIS,
)

import colour

print("// colour-science %s, SDS_BASIS_FUNCTIONS_CIE_ILLUMINANT_D_SERIES, 10 nm rows" % colour.__version__)
for name in ("S0", "S1", "S2"):
    sd = BASIS[name]
    wl, v = sd.wavelengths, sd.values
    assert wl[0] == 300 and wl[-1] == 830 and np.all(np.diff(wl) == 5), name
    mid = 0.5 * (v[0:-1:2] + v[2::2])
    assert np.max(np.abs(v[1::2] - mid)) < 1e-9, name
    rows = [float(u) for u in v[::2]]
    print("const %s: [f64; %d] = [" % (name, len(rows)))
    for i in range(0, len(rows), 9):
        print("    " + " ".join("%s," % repr(round(u, 4)) for u in rows[i : i + 9]))
    print("];")
