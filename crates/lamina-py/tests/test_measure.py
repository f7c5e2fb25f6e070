"""Sensors from Python: the same numbers as the CLI's files, every band, errors."""

import csv

import numpy as np
import pytest

import lamina


def rows(path):
    with open(path) as f:
        lines = [l for l in f if not l.startswith("#")]
    return list(csv.DictReader(lines))


@pytest.fixture
def rami(cli, tmp_path):
    d = tmp_path / "hom11"
    cli("canopy", "rami", "--case", "HOM11", "--band", "nir", "--cell", "2",
        "--brf-samples", "256", "--photons", "20000", "-o", d)
    return d


def test_measure_equals_the_cli_files(cli, rami):
    cli("render", rami / "scene.toml", "--seed", "5", "--threads", "2", "-q")
    out = lamina.measure(lamina.load_scene(rami / "scene.toml"), seed=5, threads=1)
    assert [o["type"] for o in out] == ["brf", "absorbed"]
    brf, flux = out
    assert brf["channels"] == ["R", "G", "B"] and brf["channel"] == "R"
    pp = rows(rami / "brfpp.csv")
    sweep = brf["sweeps"][0]
    assert sweep["label"] == "principal plane"
    assert sweep["brf"].shape == (76, 3)
    np.testing.assert_allclose(sweep["zenith"], [float(r["vza"]) for r in pp], atol=1e-4)
    np.testing.assert_allclose(sweep["brf"][:, 0], [float(r["brf"]) for r in pp], atol=1e-6)
    np.testing.assert_allclose(sweep["std"][:, 0], [float(r["std"]) for r in pp], atol=1e-6)
    f = {r["measure"]: float(r["value"]) for r in rows(rami / "fluxes.csv")}
    for k in ("albedo", "fabs", "ftran"):
        assert flux[k]["value"][0] == pytest.approx(f[k], abs=1e-6)
    budget = flux["albedo"]["value"] + flux["fabs"]["value"] + flux["ftran"]["value"] * (1 - 0.159)
    np.testing.assert_allclose(budget, 1.0, atol=0.01)
    assert set(flux["materials"]) == {"leaf", "soil"}
    assert set(flux["objects"]) == {"soil", "leaves"}


def test_measure_in_bands_and_sample_scale(rami):
    s = lamina.load_scene(rami / "scene.toml")
    bands = [{"name": "red", "center": 665, "width": 30},
             {"name": "nir", "center": 865, "width": 40},
             {"name": "swir", "center": 1600, "width": 50},
             {"name": "green", "center": 550, "width": 40}]
    # All at once: the channels name bands that only exist with them.
    s.update({"film.bands": bands, "sensor[0].channel": "nir", "sensor[1].channel": "green"})
    out = lamina.measure(s, sample_scale=0.5)
    assert out[0]["channels"] == ["red", "nir", "swir", "green"]
    assert out[0]["sweeps"][0]["brf"].shape == (76, 4)
    assert out[0]["samples"] == 256
    assert out[1]["albedo"]["value"].shape == (4,)
    assert not np.isnan(out[1]["albedo"]["value"]).any()


def test_measure_errors_and_a_scene_without_sensors(rami, small_dict):
    assert lamina.measure(lamina.Scene.from_dict(small_dict)) == []
    s = lamina.load_scene(rami / "scene.toml")
    with pytest.raises(ValueError, match="sample_scale"):
        lamina.measure(s, sample_scale=0)
    with pytest.raises(ValueError, match="threads"):
        lamina.measure(s, threads=0)
    with pytest.raises(lamina.SceneError, match="not above the horizon"):
        s.set("sensor[0].directions", [[95, 0]])
