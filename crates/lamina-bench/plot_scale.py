#!/usr/bin/env python3
"""Plots the scale benchmark: `python3 plot_scale.py scale.json scale.png [frames.png]`.

Four panels against leaves in the scene (log-log): peak memory, BVH bytes, BVH build time
and seconds per frame, one line per representation (flat cards, instanced curved leaves,
forest of instanced trees). With a third path, also a contact sheet of the runs' frames
(`frame_*.png` beside scale.json, as the benchmark names them): one row per leaf count,
flat | instanced, then the forests."""
import json
import os
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


def main():
    src, dst = sys.argv[1], sys.argv[2]
    data = json.load(open(src))
    # {"generator": "lamina-bench scale", "runs": [...]} (a bare list before 2026-12-04).
    rows = data["runs"] if isinstance(data, dict) else data
    reps = []
    for r in rows:
        if r["representation"] not in reps:
            reps.append(r["representation"])
    panels = [
        ("peak_rss_bytes", "peak memory (MiB)", 1 / 2**20),
        ("bvh_bytes", "BVH + primitive records (MiB)", 1 / 2**20),
        ("bvh_build_s", "BVH build (s)", 1),
        ("render_s", "seconds per frame", 1),
    ]
    fig, axes = plt.subplots(1, 4, figsize=(18, 4.5))
    style = {"flat": "o-", "instanced": "s-", "forest": "^--", "forest-curved": "v--"}
    for ax, (key, label, scale) in zip(axes, panels):
        for rep in reps:
            pts = sorted((r["leaves"], r[key] * scale) for r in rows if r["representation"] == rep)
            if pts:
                ax.plot(*zip(*pts), style.get(rep, "x-"), label=rep)
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel("leaves in the scene")
        ax.set_title(label)
        ax.grid(True, which="both", alpha=0.3)
    axes[0].legend()
    r0 = rows[0]
    fig.suptitle(
        "lamina scale benchmark: %dx%d, %d spp, %d threads (flat cards vs instanced curved leaves)"
        % (r0["resolution"][0], r0["resolution"][1], r0["spp"], r0["threads"])
    )
    fig.tight_layout()
    save(fig, dst, dpi=110)
    if len(sys.argv) > 3:
        contact_sheet(rows, Path(src).parent, sys.argv[3])


def save(fig, dst, dpi):
    """Writes `fig` to the PNG `dst` with lamina's mark (a `Software` text chunk starting
    with "lamina", so that the benchmark may replace it next time), through a temporary
    file and a rename: never half-written."""
    dst = Path(dst)
    tmp = dst.with_name("." + dst.name + ".tmp.png")
    fig.savefig(tmp, dpi=dpi, metadata={"Software": "lamina-bench scale (matplotlib)"})
    os.replace(tmp, dst)


def frame_name(r):
    """The frame file of run `r`, as `scale` writes it."""
    rep = r["representation"]
    if rep.startswith("forest"):
        return "frame_%s_%dx%d.png" % (rep, r["trees"], r["leaves"] // max(r["trees"], 1))
    return "frame_%s_%d.png" % (rep, r["leaves"])


def count(n):
    """10000 -> "10k", 1000000 -> "1M"."""
    return "%gM" % (n / 1e6) if n >= 1_000_000 else "%gk" % (n / 1e3) if n >= 1000 else str(n)


def contact_sheet(rows, folder, dst):
    """The frames two per row: per leaf count the representations side by side, then the
    forests; each titled with its run and seconds per frame."""
    cells = [r for r in rows if (folder / frame_name(r)).exists()]
    if not cells:
        sys.exit(f"no frame_*.png in {folder}")
    ncols = 2
    nrows = (len(cells) + ncols - 1) // ncols
    fig, axes = plt.subplots(nrows, ncols, figsize=(ncols * 6.4, nrows * 3.9), squeeze=False)
    for ax in axes.flat:
        ax.axis("off")
    for ax, r in zip(axes.flat, cells):
        ax.imshow(plt.imread(folder / frame_name(r)))
        what = ("%d x %s" % (r["trees"], count(r["leaves"] // r["trees"]))
                if r["representation"].startswith("forest") else count(r["leaves"]))
        ax.set_title("%s %s: %.1f s / frame" % (what, r["representation"], r["render_s"]), fontsize=11)
    fig.tight_layout()
    save(fig, dst, dpi=80)


if __name__ == "__main__":
    main()
