"""Leaf optics: the BSDF over arrays, equal to the Rust values; albedo; PROSPECT; fits."""

import csv
import pathlib

import numpy as np
import pytest

import lamina

REF = pathlib.Path(__file__).resolve().parents[2] / "lamina-leaf/tests/data/bsdf_reference.csv"


def leaves():
    return {
        "default": lamina.Leaf.from_dict({}),
        "pigments_cab40": lamina.Leaf.from_dict({"pigments": {"cab": 40}}),
    }


def test_bsdf_equals_the_rust_values():
    rows = list(csv.DictReader(REF.open()))
    assert len(rows) == 50
    ls = leaves()
    for name, leaf in ls.items():
        mine = [r for r in rows if r["leaf"] == name]
        wo = np.array([[float(r[f"wo_{c}"]) for c in "xyz"] for r in mine])
        wi = np.array([[float(r[f"wi_{c}"]) for c in "xyz"] for r in mine])
        f = np.array([[float(r[f"f_{c}"]) for c in "rgb"] for r in mine], dtype=np.float32)
        pdf = np.array([float(r["pdf"]) for r in mine], dtype=np.float32)
        assert np.array_equal(leaf.eval(wo, wi).astype(np.float32), f), name
        assert np.array_equal(leaf.pdf(wo, wi).astype(np.float32), pdf), name


def test_shapes_and_broadcasting():
    leaf = lamina.Leaf.species("maple", resolution=64)
    wo = [0, 0, 1]
    wi = np.random.default_rng(1).normal(size=(100, 3))
    f = leaf.eval(wo, wi)
    assert f.shape == (100, 3) and f.dtype == np.float64
    assert leaf.eval(wo, wi[0]).shape == (3,)
    assert np.allclose(leaf.eval(wo, wi[0]), f[0])
    uv = np.tile([0.5, 0.5], (100, 1))
    assert np.array_equal(leaf.eval(wo, wi, uv=uv), leaf.eval(wo, wi, uv=[0.5, 0.5]))
    assert leaf.pdf(wo, wi).shape == (100,)
    assert isinstance(leaf.pdf(wo, wi[0]), float)
    # Directions need not be unit length.
    assert np.allclose(leaf.eval(wo, 5 * wi), f)


def test_sampling_weights_match_eval_over_pdf():
    leaf = lamina.Leaf.species("beech", resolution=64)
    rng = np.random.default_rng(2)
    u = rng.random((20000, 3))
    wo = np.array([0.2, 0.1, 0.97])
    wi, f, pdf = leaf.sample(wo, u)
    ok = pdf > 0
    assert ok.mean() > 0.5
    assert np.allclose(np.linalg.norm(wi[ok], axis=1), 1, atol=1e-5)
    assert np.allclose(f[ok], leaf.eval(wo, wi[ok]), rtol=1e-4, atol=1e-7)
    assert np.allclose(pdf[ok], leaf.pdf(wo, wi[ok]), rtol=1e-4)
    # On a leaf without maps (every texel alike) the mean weight is the albedo at this wo.
    plain = lamina.Leaf.from_dict({})
    wi, f, pdf = plain.sample(wo, u)
    ok = pdf > 0
    r, t = plain.albedo(theta=np.degrees(np.arccos(wo[2] / np.linalg.norm(wo))))
    w = np.where(ok[:, None], f / np.where(ok, pdf, 1)[:, None], 0).mean(axis=0)
    assert np.allclose(w, r + t, atol=0.01), (w, r + t)


def test_albedo_rgb_and_spectral():
    r, t = lamina.Leaf.species("maple").albedo()
    # `lamina leaf albedo --species maple` prints 549 nm R 0.1875 T 0.3252.
    assert r[1] == pytest.approx(0.1875, abs=5e-4) and t[1] == pytest.approx(0.3252, abs=5e-4)
    leaf = lamina.Leaf.from_dict({"pigments": {"cab": 40}})
    assert leaf.is_pigment and leaf.pigments["cab"] == 40.0
    nm = np.array([550.0, 680.0, 850.0, 1600.0])
    r, t = leaf.albedo(wavelengths=nm)
    wl, pr, pt = lamina.prospect(cab=40)
    idx = (nm - 400).astype(int)
    # The leaf is calibrated to PROSPECT at 8 degrees (RMSE 0.01 is the bar).
    assert np.allclose(r, pr[idx], atol=0.015) and np.allclose(t, pt[idx], atol=0.015)
    with pytest.raises(lamina.LeafError, match="pigment leaf"):
        lamina.Leaf.species("maple", resolution=32).albedo(wavelengths=[550])
    with pytest.raises(ValueError, match="400-2500"):
        leaf.albedo(wavelengths=[300])
    with pytest.raises(ValueError, match="theta"):
        leaf.albedo(theta=95)
    with pytest.raises(ValueError, match="side"):
        leaf.albedo(side="top")


def test_prospect_equals_the_reference_leaf():
    wl, r, t = lamina.prospect(n=1.5, cab=40, car=8, anth=0, cbrown=0, cw=0.012, cm=0.009)
    assert wl.shape == r.shape == t.shape == (2101,)
    assert wl[0] == 400 and wl[-1] == 2500
    assert np.all((r > 0) & (r < 1) & (t >= 0) & (r + t < 1))
    # Green peak, red well, NIR plateau.
    assert r[150] > r[280] and r[450] > 0.4
    wl2, r2, t2 = lamina.prospect(model="pro", prot=0.001, cbc=0.009)
    assert not np.allclose(r, r2)


@pytest.mark.parametrize(
    "kw, words",
    [
        ({"cab": 300}, "cab"),
        ({"n": float("nan")}, "`n`"),
        ({"prot": 0.001}, "model='pro'"),
        ({"model": "pro", "cm": 0.01}, "cm"),
        ({"model": "x"}, "model"),
    ],
)
def test_prospect_errors(kw, words):
    with pytest.raises(lamina.LeafError) as e:
        lamina.prospect(**kw)
    assert words in str(e.value)


def test_fit_recovers_a_prospect_leaf():
    wl, r, t = lamina.prospect(n=1.8, cab=55, car=11, cw=0.015, cm=0.006)
    noise = np.random.default_rng(3).normal(scale=0.002, size=(2, wl.size))
    fit = lamina.fit_leaf(wl[::5], np.clip(r + noise[0], 0, 1)[::5], np.clip(t + noise[1], 0, 1)[::5])
    p = fit["pigments"]
    assert p["n"] == pytest.approx(1.8, rel=0.05)
    assert p["cab"] == pytest.approx(55, rel=0.1)
    assert fit["rmse_r"] < 0.005 and fit["rmse_t"] < 0.005
    assert fit["model_r"].shape == (421,)
    # The fitted pigments make a leaf.
    assert lamina.Leaf.from_dict({"pigments": {k: v for k, v in p.items() if k != "model"}})


def test_fit_band_weight():
    wl, r, t = lamina.prospect(n=1.8, cab=55, car=11, cw=0.015, cm=0.006)
    # A SWIR unlike PROSPECT's: the band terms pull that band's mean in.
    bump = 0.03 * np.exp(-(((wl - 1650.0) / 120.0) ** 2))
    r = r - bump
    swir = (wl >= 1550) & (wl <= 1750)
    err = {}
    for w in (0.0, 8.0):
        with pytest.warns(UserWarning, match="transmittance"):
            fit = lamina.fit_leaf(wl[::4], r[::4], band_weight=w)
        model = np.interp(wl[swir], fit["wavelengths"], fit["model_r"])
        err[w] = abs(model.mean() - r[swir].mean())
    assert err[8.0] < 0.01 and err[8.0] < 0.7 * err[0.0], err
    for bad in (-1.0, float("nan"), 2000.0):
        with pytest.raises(lamina.LeafError, match="band_weight"):
            lamina.fit_leaf(wl[::10], r[::10], band_weight=bad)


def test_fit_without_t_warns():
    wl, r, t = lamina.prospect(cab=30)
    with pytest.warns(UserWarning, match="transmittance"):
        fit = lamina.fit_leaf(wl[::10], r[::10])
    assert fit["rmse_t"] is None


@pytest.mark.parametrize(
    "wl, r, t, words",
    [
        ([500, 400, 600] + list(range(700, 1500, 100)), [0.1] * 11, None, "sample 1"),
        (list(range(400, 1500, 100)), [0.1] * 10 + [1.5], None, "sample 10"),
        (list(range(400, 1500, 100)), [0.1] * 5 + [float("nan")] + [0.1] * 5, None, "sample 5"),
        (list(range(400, 1500, 100)), [0.6] * 11, [0.6] * 11, "reflectance + transmittance"),
        (list(range(400, 900, 100)), [0.1] * 5, None, "10"),
        (list(range(400, 1500, 100)), [0.1] * 10, None, "same length"),
        (list(range(3000, 4100, 100)), [0.1] * 11, None, "400-2500"),
    ],
)
def test_fit_errors(wl, r, t, words):
    with pytest.raises(lamina.LeafError) as e:
        lamina.fit_leaf(wl, r, t)
    assert words in str(e.value), str(e.value)


def test_leaf_construction_errors(tmp_path):
    with pytest.raises(lamina.LeafError, match="palm"):
        lamina.Leaf.species("palm")
    with pytest.raises(lamina.LeafError):
        lamina.Leaf.load(tmp_path / "missing")
    with pytest.raises(lamina.LeafError, match="colour|color|chlorophyll|unknown"):
        lamina.Leaf.from_dict({"pigments": {"chlorophyll": 40}})
    with pytest.raises(lamina.LeafError, match="front"):
        lamina.Leaf.from_dict({"maps": {"front": "nope.png"}}, base_dir=tmp_path)


def test_bad_arrays():
    leaf = lamina.Leaf.from_dict({})
    with pytest.raises(ValueError, match=r"shape \(3,\) or \(N, 3\)"):
        leaf.eval([[0, 0, 1, 0]], [0, 0, 1])
    with pytest.raises(ValueError, match=r"wi\[1\]"):
        leaf.eval([0, 0, 1], [[0, 0, 1], [0, 0, float("nan")]])
    with pytest.raises(ValueError, match=r"wo\[0\]"):
        leaf.eval([0, 0, 0], [0, 0, 1])
    with pytest.raises(ValueError, match="rows"):
        leaf.eval(np.ones((3, 3)), np.ones((4, 3)))
    with pytest.raises(ValueError, match="uniform"):
        leaf.sample([0, 0, 1], [0.5, 0.5, 1.5])
    with pytest.raises(ValueError):
        leaf.eval("up", [0, 0, 1])
    with pytest.raises(ValueError, match=r"uv"):
        leaf.eval([0, 0, 1], [0, 0, 1], uv=[0.5])


def test_leaf_folder_roundtrip(cli, tmp_path):
    out = tmp_path / "oak"
    cli("leaf", "generate", "--species", "oak", "--resolution", "64", "-o", out)
    leaf = lamina.Leaf.load(out)
    assert "oak" in repr(leaf)
    r, t = leaf.albedo()
    assert np.all((r > 0) & (t > 0) & (r + t < 1))
