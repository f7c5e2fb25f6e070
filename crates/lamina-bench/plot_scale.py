#!/usr/bin/env python3
"""Plots the scale benchmark: `python3 plot_scale.py scale.json scale.png`.

Four panels against leaves in the scene (log-log): peak memory, BVH bytes, BVH build time
and seconds per frame, one line per representation (flat cards, instanced curved leaves,
forest of instanced trees)."""
import json
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


def main():
    src, dst = sys.argv[1], sys.argv[2]
    rows = json.load(open(src))
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
    fig.savefig(dst, dpi=110)


if __name__ == "__main__":
    main()
