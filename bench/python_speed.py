"""The Python package's speed next to the CLI's, side by side in one run.

    python bench/python_speed.py [--scene examples/leaf_cards.toml] [--spp 64] [--repeat 3]

Needs the `lamina` package installed (pip install ./crates/lamina-py) and the release CLI
(target/release/lamina, or $LAMINA_BIN). Prints, for the same scene, seed and spp:
  * render time: the CLI's own summary line ("in X s") against `lamina.render`'s
    stats["elapsed"] (the same lamina_render::render call), and wall-clock time of the
    whole job (CLI process: load + render + write; Python: load_scene + render +
    write_image), best of --repeat runs each, alternating;
  * leaf BSDF evaluations per second per core from Python (`Leaf.eval` over 1e6
    directions, with threads = 1 via RAYON_NUM_THREADS in a subprocess), for the layered
    model (default), Eq. (1) and the diffuse mode.
"""

import argparse
import os
import pathlib
import re
import subprocess
import sys
import tempfile
import time

REPO = pathlib.Path(__file__).resolve().parents[1]

EVAL = r"""
import sys, time, numpy as np, lamina
mode = sys.argv[1]
leaf = lamina.Leaf.from_dict({"params": {"mode": mode}} if mode != "layered" else {})
rng = np.random.default_rng(0)
wi = rng.normal(size=(1_000_000, 3)); wi /= np.linalg.norm(wi, axis=1)[:, None]
wo = np.array([0.3, 0.1, 0.95]); wo /= np.linalg.norm(wo)
leaf.eval(wo, wi[:1000])
best = 1e9
for _ in range(3):
    t = time.perf_counter(); leaf.eval(wo, wi); best = min(best, time.perf_counter() - t)
print(f"{1e6 / best / 1e6:.2f}")
"""


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--scene", default=str(REPO / "examples/leaf_cards.toml"))
    ap.add_argument("--spp", type=int, default=64)
    ap.add_argument("--repeat", type=int, default=3)
    a = ap.parse_args()
    import lamina

    cli = os.environ.get("LAMINA_BIN") or str(REPO / "target/release/lamina")
    tmp = pathlib.Path(tempfile.mkdtemp())
    cli_render, cli_wall, py_render, py_wall = [], [], [], []
    for _ in range(a.repeat):
        t = time.perf_counter()
        r = subprocess.run(
            [cli, "render", a.scene, "--spp", str(a.spp), "-q", "-o", str(tmp / "cli.png")],
            capture_output=True, text=True, check=True,
        )
        cli_wall.append(time.perf_counter() - t)
        cli_render.append(float(re.search(r" in ([0-9.]+) s", r.stderr).group(1)))
        t = time.perf_counter()
        s = lamina.load_scene(a.scene)
        img, st = lamina.render(s, spp=a.spp, stats=True)
        lamina.write_image(tmp / "py.png", img, s)
        py_wall.append(time.perf_counter() - t)
        py_render.append(st["elapsed"])
    same = (tmp / "cli.png").read_bytes() == (tmp / "py.png").read_bytes()
    print(f"scene {a.scene}, {a.spp} spp, {os.cpu_count()} cores, best of {a.repeat}")
    print(f"  render call: CLI {min(cli_render):.3f} s, Python {min(py_render):.3f} s, "
          f"Python/CLI = {min(py_render) / min(cli_render):.3f}")
    print(f"  whole job:   CLI {min(cli_wall):.3f} s, Python {min(py_wall):.3f} s, "
          f"Python/CLI = {min(py_wall) / min(cli_wall):.3f}")
    print(f"  PNGs identical: {same}")
    env = dict(os.environ, RAYON_NUM_THREADS="1")
    for mode in ["layered", "eq1", "diffuse"]:
        r = subprocess.run([sys.executable, "-c", EVAL, mode], env=env,
                           capture_output=True, text=True, check=True)
        print(f"  Leaf.eval, {mode:8}: {r.stdout.strip()} M evaluations/s on one core")


if __name__ == "__main__":
    main()
