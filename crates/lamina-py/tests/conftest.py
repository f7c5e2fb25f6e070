"""Shared fixtures of the lamina Python tests: the repository, the CLI binary, scenes."""

import os
import pathlib
import shutil
import subprocess

import pytest

REPO = pathlib.Path(__file__).resolve().parents[3]


def lamina_bin():
    """The `lamina` CLI to compare with: $LAMINA_BIN, or the workspace's release build."""
    env = os.environ.get("LAMINA_BIN")
    if env:
        return env
    p = REPO / "target" / "release" / "lamina"
    return str(p) if p.exists() else None


@pytest.fixture
def cli():
    b = lamina_bin()
    if b is None:
        if os.environ.get("CI"):
            pytest.fail("CI must provide the lamina binary (LAMINA_BIN or target/release)")
        pytest.skip("no lamina binary (build it with cargo build --release -p lamina-cli)")

    def run(*args, check=True):
        r = subprocess.run([b, *map(str, args)], capture_output=True, text=True)
        if check and r.returncode != 0:
            raise AssertionError(f"lamina {' '.join(map(str, args))} failed:\n{r.stderr}")
        return r

    return run


SMALL = {
    "camera": {"position": [0.0, 0.35, 0.9], "look_at": [0.0, 0.1, 0.0], "fov": 45},
    "film": {"width": 48, "height": 32, "spp": 4},
    "sky": {"type": "constant", "radiance": [0.15, 0.2, 0.3]},
    "light": [{"type": "sun", "direction": [-0.4, 0.5, -1.0], "irradiance": 3.0}],
    "material": [
        {"name": "leaf", "type": "leaf", "species": "maple"},
        {"name": "soil", "type": "diffuse", "reflectance": [0.12, 0.09, 0.06]},
    ],
    "object": [
        {
            "type": "quad",
            "material": "leaf",
            "corner": [-0.15, 0.05, 0.0],
            "edge_u": [0.3, 0.0, 0.0],
            "edge_v": [0.0, 0.25, 0.0],
        },
        {
            "type": "quad",
            "material": "soil",
            "corner": [-2.0, 0.0, 2.0],
            "edge_u": [4.0, 0.0, 0.0],
            "edge_v": [0.0, 0.0, -4.0],
        },
    ],
}


@pytest.fixture
def small_dict():
    import copy

    return copy.deepcopy(SMALL)


@pytest.fixture
def scene_file(tmp_path):
    """examples/leaf_cards.toml copied with its card file into a scratch folder."""
    for f in ["leaf_cards.toml", "cards.csv"]:
        shutil.copy(REPO / "examples" / f, tmp_path / f)
    return tmp_path / "leaf_cards.toml"
