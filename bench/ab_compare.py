#!/usr/bin/env python3
"""Times two lamina binaries on one scene, alternating, and says whether they render the same.

On a shared machine a single run of the same binary moves by 10-15 % from minute to minute,
so a change of a few percent shows only in many runs taken side by side. This script runs
binary A and binary B in pairs, alternating which goes first (A B, B A, A B, ...: slow drifts
of the machine fall on both), and prints per binary the median and the minimum of the render
seconds lamina reports and of the CPU seconds (user + system) its process used, then the ratio
B / A of the medians and the median of the pairs' ratios. The images of each binary's last
run are compared byte for byte (the renders are deterministic: the same scene, seed and
sample count give the same image, so a change meant to keep the numbers must print
"identical").

    python3 bench/ab_compare.py /tmp/lamina_before target/release/lamina out/mitsuba_compare/scene.toml
    python3 bench/ab_compare.py A B SCENE --pairs 10 --spp 16        # the first passes only
    python3 bench/ab_compare.py A B SCENE --pairs 6 -- --one-path-at-a-time

Arguments after `--` go to both `lamina render` commands. The images go to a temporary
folder, removed afterwards; nothing else is written.
"""

import argparse
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
import common  # noqa: E402


def executable(path):
    p = Path(path)
    if not p.is_file():
        raise argparse.ArgumentTypeError(f"{path}: no such file")
    if not os.access(p, os.X_OK):
        raise argparse.ArgumentTypeError(f"{path}: not executable")
    return p


def scene_file(path):
    p = Path(path)
    if not p.is_file():
        raise argparse.ArgumentTypeError(f"{path}: no such scene file")
    return p


def at_least(n):
    def check(text):
        try:
            v = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{text!r} is not a whole number")
        if v < n:
            raise argparse.ArgumentTypeError(f"must be at least {n} (got {v})")
        return v
    return check


def run(binary, scene, image, extra):
    """One render: (render seconds lamina printed, CPU seconds of its process, wall seconds)."""
    cmd = [str(binary), "render", str(scene), "-o", str(image), "--force", "--quiet"] + extra
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    r = subprocess.run(cmd, capture_output=True, text=True)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if r.returncode != 0:
        sys.exit(f"error: {' '.join(cmd)} failed (exit {r.returncode}):\n{r.stderr.strip()}")
    m = common.SUMMARY_RE.search(r.stderr)
    if not m:
        sys.exit(f"error: {' '.join(cmd)}: no summary line ('... spp in X s: ...') in its output:\n"
                 f"{r.stderr.strip()}")
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return float(m.group(4)), cpu, wall


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                 usage="%(prog)s A B SCENE [--pairs N] [--spp N] [--threads N] "
                                       "[-- LAMINA RENDER ARGS...]")
    ap.add_argument("a", type=executable, help="binary A (the reference)")
    ap.add_argument("b", type=executable, help="binary B (the change)")
    ap.add_argument("scene", type=scene_file, help="the lamina scene (TOML)")
    ap.add_argument("--pairs", type=at_least(2), default=6,
                    help="pairs of runs (default 6; at least 2)")
    ap.add_argument("--spp", type=at_least(1), help="samples per pixel (default: the scene's)")
    ap.add_argument("--threads", type=at_least(1), help="render threads (default: lamina's)")
    argv = sys.argv[1:]
    # Everything after `--` goes to `lamina render` (argparse would read it as options).
    extra = argv[argv.index("--") + 1:] if "--" in argv else []
    args = ap.parse_args(argv[:argv.index("--")] if "--" in argv else argv)
    if args.spp is not None:
        extra += ["--spp", str(args.spp)]
    if args.threads is not None:
        extra += ["--threads", str(args.threads)]

    runs = {"A": [], "B": []}
    with tempfile.TemporaryDirectory(prefix="lamina_ab_") as tmp:
        images = {"A": Path(tmp) / "a.exr", "B": Path(tmp) / "b.exr"}
        binaries = {"A": args.a, "B": args.b}
        for i in range(args.pairs):
            order = ("A", "B") if i % 2 == 0 else ("B", "A")
            got = {}
            for k in order:
                got[k] = run(binaries[k], args.scene, images[k], extra)
                runs[k].append(got[k])
            print(f"pair {i + 1}: A {got['A'][0]:.2f} s ({got['A'][1]:.2f} CPU s), "
                  f"B {got['B'][0]:.2f} s ({got['B'][1]:.2f} CPU s), "
                  f"B / A {got['B'][0] / got['A'][0]:.3f}", flush=True)
        same = images["A"].read_bytes() == images["B"].read_bytes()

    rows = []
    for j, what in ((0, "render s"), (1, "CPU s")):
        a = [r[j] for r in runs["A"]]
        b = [r[j] for r in runs["B"]]
        ratios = [y / x for x, y in zip(a, b)]
        rows.append([what, "%.3f" % statistics.median(a), "%.3f" % min(a),
                     "%.3f" % statistics.median(b), "%.3f" % min(b),
                     "%.3f" % (statistics.median(b) / statistics.median(a)),
                     "%.3f" % statistics.median(ratios)])
    model, ncpu = common.cpu_info()
    busy = " (a compile was running: times are not reliable)" if common.compile_running() else ""
    print(f"\n{args.scene}, {args.pairs} pairs (alternating first); {ncpu} CPUs, {model}{busy}:")
    print(common.fmt_table(rows, ["", "A median", "A min", "B median", "B min",
                                  "B / A (medians)", "median of pair ratios"]))
    print("images: " + ("identical (byte for byte)" if same else "DIFFERENT"))


if __name__ == "__main__":
    main()
