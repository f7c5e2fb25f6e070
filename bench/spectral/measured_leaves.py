#!/usr/bin/env python3
"""Extract real, measured leaf reflectance spectra (not PROSPECT output) for `lamina leaf fit`.

Usage:
    python3 bench/spectral/measured_leaves.py -o /tmp/measured_leaves
    python3 bench/spectral/measured_leaves.py --source speclib-1.0.1.tar.gz -o DIR
    python3 bench/spectral/measured_leaves.py --list            # every leaf-like spectrum on offer
    python3 bench/spectral/measured_leaves.py --ids oak_oak-leaf-1_fresh,maple_leaves -o DIR

Where the data come from
------------------------
The PyPI package `speclib` 1.0.1 (GPL-3.0 code) carries, in its *source distribution only*
(`docs/data/spectra/*.json`, index in `docs/data/catalog.json`; the wheel has none of it),
a copy of the USGS Spectral Library Version 7 (Kokaly et al. 2017, USGS Data Series 1035,
doi:10.3133/ds1035; US public domain), chapter V (vegetation), at the instruments' native
sampling ("splib07a"): ASD FieldSpec (2151 channels, 350-2500 nm, 1 nm) or Beckman 5270 lab
spectrometer (480 channels over 0.2-3.0 um, 1.6-30 nm apart in 400-2500 nm). These are
REFLECTANCE ONLY (no transmittance), measured on single leaves or leaf samples in the lab.
The same sdist has Kentucky Lonicera maackii leaf spectra (CC-BY-4.0, CID CI-710, 345-1035 nm
only) which `--list` shows but the default set skips (they miss the SWIR).

`pip install speclib` does NOT bring the data; this script reads the sdist tarball. Give it with
`--source` (tar.gz or its unpacked folder), or let the script fetch it from PyPI with pip
(`pip download --no-deps --no-binary :all: speclib==1.0.1`) into --cache (default
~/.cache/lamina-bench); `--no-download` forbids that.

What to expect from a PROSPECT fit (checked outside lamina: prosail 2.0.5's PROSPECT-D table,
scipy least squares on R alone, N in [1, 6]): aspen Aspen-1 and Leaf-A RMSE ~0.008-0.009 with
N ~1.6 (single leaves on black, the easy cases); walnut 0.014; maple 0.011 but only with
N 3.4 and Cab at 120 (looks like a stack); oak Oak-Leaf-1 (R(860) = 0.86) and Russian olive
(scaly, silvery leaves, R(860) = 0.72) 0.03-0.05 with N at its bound: brighter in the NIR than
any single PROSPECT leaf, kept as the hard cases. None is a PROSPECT output (a PROSPECT-5
spectrum refits to ~1e-8).

Output: one CSV per leaf, `wavelength_nm,reflectance`, 400-2500 nm, native channels only
(USGS "deleted channel" NaNs dropped, nothing interpolated), plus `sources.tsv` with provenance.
Stdlib only (no numpy).
"""
import argparse
import csv
import io
import json
import math
import os
import subprocess
import sys
import tarfile
from pathlib import Path

SPECLIB_VERSION = "1.0.1"
SDIST_NAME = f"speclib-{SPECLIB_VERSION}.tar.gz"
WL_MIN, WL_MAX = 400.0, 2500.0
PROBES = (550.0, 670.0, 860.0, 1650.0)

# Default set: green leaves of six species, all covering (most of) 400-2500 nm.
# key = the speclib id without the "usgs_splib07_vegetation_" prefix and the hash suffix.
# Species and sample notes: from the speclib catalog (name, instrument) and, where marked
# "USGS:", from the USGS splib sample description pages; the rest is the USGS sample name.
DEFAULT_LEAVES = [
    ("oak_oak-leaf-1_fresh", "Quercus robur (oak)",
     "USGS: single fresh leaf lying flat on a strongly absorbing bench top, measured within "
     "10 min of cutting; Lakewood, Colorado"),
    ("aspen_aspen-1_green-top", "Populus tremuloides (quaking aspen)",
     "upper surface of a green leaf; USGS (Aspen-3 of the same series): single leaf on a black "
     "(~0 %) background, bare fibre 3 cm above it; Boulder, Colorado"),
    ("aspen_leaf-a_dw92-2", "aspen (Populus)", "USGS lab sample DW92-2, Beckman"),
    ("maple_leaves_dw92-1", "maple (Acer)", "USGS lab sample DW92-1 (leaves), Beckman"),
    ("walnut_leaf_sun_(green)", "walnut (Juglans)", "sun leaf, green; Beckman"),
    ("russian_olive_dw92-4", "Elaeagnus angustifolia (Russian olive)",
     "USGS lab sample DW92-4, Beckman"),
]

LEAFY_WORDS = ("leaf", "leaves", "olive", "needle", "needls", "grn", "green", "gr.a", "dkgrn", "grass")
USGS_PREFIX = "usgs_splib07_vegetation_"


class Sdist:
    """Read members of the speclib sdist, from a .tar.gz or an unpacked folder."""

    def __init__(self, path: Path):
        self.path = path
        self.tar = None
        if path.is_dir():
            roots = [path] + [p for p in path.iterdir() if p.is_dir()]
            self.root = next((r for r in roots if (r / "docs/data/catalog.json").exists()), None)
            if self.root is None:
                sys.exit(f"{path}: no docs/data/catalog.json (not an unpacked speclib sdist)")
        else:
            self.tar = tarfile.open(path, "r:gz")
            names = {m.name: m for m in self.tar.getmembers()}
            self.members = names
            cat = [n for n in names if n.endswith("docs/data/catalog.json")]
            if not cat:
                sys.exit(f"{path}: no docs/data/catalog.json inside (not a speclib sdist?)")
            self.prefix = cat[0][: -len("docs/data/catalog.json")]

    def read(self, rel: str) -> bytes:
        if self.tar is None:
            return (self.root / rel).read_bytes()
        m = self.members.get(self.prefix + rel)
        if m is None:
            raise FileNotFoundError(rel)
        return self.tar.extractfile(m).read()

    def describe(self) -> str:
        return str(self.path)


def locate_sdist(args) -> Path:
    if args.source:
        p = Path(args.source).expanduser()
        if not p.exists():
            sys.exit(f"--source {p} does not exist")
        return p
    env = os.environ.get("SPECLIB_SDIST")
    if env and Path(env).exists():
        return Path(env)
    cache = Path(args.cache).expanduser()
    cached = cache / SDIST_NAME
    if cached.exists():
        return cached
    if args.no_download:
        sys.exit(f"no speclib sdist: pass --source, set SPECLIB_SDIST, or put {SDIST_NAME} in {cache}")
    cache.mkdir(parents=True, exist_ok=True)
    print(f"fetching {SDIST_NAME} from PyPI with pip into {cache} ...", file=sys.stderr)
    cmd = [sys.executable, "-m", "pip", "download", "--no-deps", "--no-binary", ":all:",
           "-q", "-d", str(cache), f"speclib=={SPECLIB_VERSION}"]
    r = subprocess.run(cmd)
    if r.returncode != 0 or not cached.exists():
        sys.exit("pip download of the speclib sdist failed; pass --source instead")
    return cached


def load_spectrum(sd: Sdist, sid: str):
    d = json.loads(sd.read(f"docs/data/spectra/{sid}.json"))
    out = []
    for w, r in zip(d["wavelengths"], d["reflectance"]):
        if w is None or r is None:
            continue
        wl = float(w) * 1000.0  # speclib stores micrometres
        rv = float(r)
        if math.isnan(rv) or not (WL_MIN - 1e-6 <= wl <= WL_MAX + 1e-6):
            continue
        out.append((wl, rv))
    out.sort()
    return d.get("name", sid), out


def interp(samples, x, max_gap=40.0):
    """Linear interpolation on the valid samples; None if x falls in a gap wider than max_gap."""
    for (w0, r0), (w1, r1) in zip(samples, samples[1:]):
        if w0 <= x <= w1:
            if w1 - w0 > max_gap:
                return None
            return r0 if w1 == w0 else r0 + (r1 - r0) * (x - w0) / (w1 - w0)
    return None


def sampling(samples):
    ws = [w for w, _ in samples]
    steps = [b - a for a, b in zip(ws, ws[1:])]
    gaps = [(a, b) for a, b in zip(ws, ws[1:]) if b - a > 35.0]
    return ws[0], ws[-1], len(ws), min(steps), max(steps), gaps


def fmt_gaps(gaps, start, end):
    parts = []
    if start > WL_MIN + 5:
        parts.append(f"{WL_MIN:.0f}-{start:.0f}")
    parts += [f"{a:.0f}-{b:.0f}" for a, b in gaps]
    if end < WL_MAX - 5:
        parts.append(f"{end:.0f}-{WL_MAX:.0f}")
    return ", ".join(parts) if parts else "none"


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("-o", "--out", help="output directory for the CSV files")
    ap.add_argument("--source", help="speclib sdist (.tar.gz) or its unpacked folder")
    ap.add_argument("--cache", default="~/.cache/lamina-bench", help="where pip puts the sdist")
    ap.add_argument("--no-download", action="store_true", help="never call pip")
    ap.add_argument("--ids", help="comma-separated id fragments to extract instead of the default six")
    ap.add_argument("--max", type=int, default=6, help="at most this many leaves (default 6)")
    ap.add_argument("--list", action="store_true", help="list leaf-like spectra on offer and exit")
    args = ap.parse_args()
    if not args.list and not args.out:
        ap.error("-o DIR is required (or --list)")

    sd = Sdist(locate_sdist(args))
    catalog = json.loads(sd.read("docs/data/catalog.json"))["spectra"]
    by_id = {c["id"]: c for c in catalog}

    if args.list:
        print("id\tinstrument\tbands\twl_um\tlicense\tname")
        for c in catalog:
            low = c["id"].lower()
            if c["source"] == "KY_FIELD" or (
                    c["category"] == "VEGETATION" and any(k in low for k in LEAFY_WORDS)
                    and not any(k in low for k in ("+", "dry", "npv", "marsh", "rangeland"))):
                print(f"{c['id']}\t{c['instrument']}\t{c['n_bands']}\t{c['wl_min']}-{c['wl_max']}"
                      f"\t{c['license']}\t{c['name']}")
        return

    if args.ids:
        wanted = [(frag.strip(), "", "") for frag in args.ids.split(",") if frag.strip()]
    else:
        wanted = DEFAULT_LEAVES
    chosen = []
    for frag, species, note in wanted:
        hits = [i for i in by_id if frag.lower() in i.lower()]
        exact = [i for i in hits if i.startswith(USGS_PREFIX + frag + "_")]
        hits = exact or hits
        if not hits:
            print(f"warning: no spectrum matches {frag!r}", file=sys.stderr)
            continue
        if len(hits) > 1 and not exact:
            print(f"warning: {frag!r} matches {len(hits)} spectra, taking {sorted(hits)[0]}",
                  file=sys.stderr)
        chosen.append((sorted(hits)[0], species, note))
    chosen = chosen[: args.max]

    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    manifest = [("file", "speclib_id", "name", "species", "source", "license", "instrument",
                 "measured", "n_points", "wl_first_nm", "wl_last_nm", "step_min_nm",
                 "step_max_nm", "gaps_nm", "notes")]
    print(f"source: {sd.describe()} (speclib {SPECLIB_VERSION} sdist, docs/data/spectra)")
    header = "file".ljust(34) + "".join(f"R{int(p):>6}" for p in PROBES) + "   T: none (reflectance only)"
    print(header)
    for sid, species, note in chosen:
        meta = by_id[sid]
        name, samples = load_spectrum(sd, sid)
        if len(samples) < 10:
            print(f"warning: {sid} has {len(samples)} valid points in 400-2500 nm, skipped",
                  file=sys.stderr)
            continue
        stem = sid[len(USGS_PREFIX):] if sid.startswith(USGS_PREFIX) else sid
        stem = stem.rsplit("_", 1)[0]  # drop speclib's hash suffix
        stem = "".join(ch if ch.isalnum() or ch in "-_." else "_" for ch in stem)
        stem = "_".join(part for part in stem.split("_") if part)
        fname = f"usgs_{stem}.csv" if sid.startswith("usgs_") else f"{stem}.csv"
        with open(out / fname, "w", newline="") as f:
            w = csv.writer(f)
            w.writerow(["wavelength_nm", "reflectance"])
            for wl, r in samples:
                w.writerow([f"{wl:.4f}".rstrip("0").rstrip("."), f"{r:.6f}"])
        first, last, n, smin, smax, gaps = sampling(samples)
        src = "USGS splib07a" if meta["source"] == "USGS_SPLIB07" else meta["source"]
        manifest.append((fname, sid, name, species or meta.get("material", ""), src,
                         meta["license"], meta["instrument"], "R only",
                         str(n), f"{first:.1f}", f"{last:.1f}", f"{smin:.2f}", f"{smax:.2f}",
                         fmt_gaps(gaps, first, last), note))
        vals = [interp(samples, p) for p in PROBES]
        print(fname.ljust(34) + "".join(f"{v:7.3f}" if v is not None else "    n/a" for v in vals))
        print(f"    {name} | {species or meta.get('material', '')} | {src}, {meta['instrument']}, "
              f"{meta['license']}")
        print(f"    {n} points {first:.1f}-{last:.1f} nm, step {smin:.2f}-{smax:.2f} nm, "
              f"missing: {fmt_gaps(gaps, first, last)}")
        if note:
            print(f"    {note}")
    with open(out / "sources.tsv", "w", newline="") as f:
        csv.writer(f, delimiter="\t", lineterminator="\n").writerows(manifest)
    print(f"wrote {len(manifest) - 1} CSV files and sources.tsv to {out}")


if __name__ == "__main__":
    main()
