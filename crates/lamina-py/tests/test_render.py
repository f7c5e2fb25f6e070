"""Renders: equal to the CLI's, deterministic, progress, time limit, the GIL, Ctrl-C."""

import os
import signal
import subprocess
import sys
import textwrap
import threading
import time

import numpy as np
import pytest

import lamina


def test_render_equals_the_cli_bit_for_bit(cli, scene_file, tmp_path):
    out = tmp_path / "cli.exr"
    cli("render", scene_file, "--spp", 3, "--seed", 7, "-q", "-o", out)
    ref, names = lamina.read_exr(out)
    assert names == ["R", "G", "B"]
    img = lamina.render(lamina.load_scene(scene_file), spp=3, seed=7)
    assert img.shape == ref.shape == (360, 480, 3)
    assert img.dtype == np.float32
    assert np.array_equal(img.view(np.uint32), ref.view(np.uint32))


def test_band_render_equals_the_cli(cli, small_dict, tmp_path):
    small_dict["film"]["bands"] = [
        {"name": "red", "min": 620, "max": 700},
        {"name": "nir", "min": 800, "max": 900},
        {"name": "green", "min": 500, "max": 570},
        {"name": "blue", "min": 450, "max": 500},
    ]
    s = lamina.Scene.from_dict(small_dict, base_dir=tmp_path)
    f = tmp_path / "bands.toml"
    f.write_text(s.to_toml())
    out = tmp_path / "bands.exr"
    cli("render", f, "--spp", 2, "--seed", 3, "-q", "-o", out)
    ref, names = lamina.read_exr(out)
    img = lamina.render(s, spp=2, seed=3)
    for k, band in enumerate(s.bands):
        assert np.array_equal(img[..., k], ref[..., names.index(band)]), band


def test_same_seed_same_image_whatever_the_threads(small_dict):
    s = lamina.Scene.from_dict(small_dict)
    a = lamina.render(s, spp=3, seed=1, threads=1)
    b = lamina.render(s, spp=3, seed=1, threads=2)
    c = lamina.render(s, spp=3, seed=2)
    assert np.array_equal(a, b)
    assert not np.array_equal(a, c)
    assert np.all(np.isfinite(a)) and a.mean() > 0.01


def test_progress_callback_and_stats(small_dict):
    s = lamina.Scene.from_dict(small_dict)
    seen = []
    img, st = lamina.render(s, spp=6, progress=seen.append, stats=True)
    assert [p["spp_done"] for p in seen] == [1, 2, 4, 6]
    assert seen[-1]["spp_total"] == 6 and seen[-1]["passes_done"] == 4
    assert st["spp"] == 6 and st["rays"] > 0 and not st["stopped_early"]
    assert img.shape == (32, 48, 3)


def test_progress_true_draws_a_bar(small_dict, capsys):
    lamina.render(lamina.Scene.from_dict(small_dict), spp=2, progress=True)
    err = capsys.readouterr().err
    assert "spp" in err


def test_an_exception_in_the_callback_cancels_and_propagates(small_dict):
    s = lamina.Scene.from_dict(small_dict)

    def boom(p):
        raise RuntimeError("stop here")

    with pytest.raises(RuntimeError, match="stop here"):
        lamina.render(s, spp=64, progress=boom)


def test_bad_options(small_dict):
    s = lamina.Scene.from_dict(small_dict)
    with pytest.raises(ValueError, match="spp"):
        lamina.render(s, spp=0)
    with pytest.raises(ValueError, match="threads"):
        lamina.render(s, threads=0)
    with pytest.raises(ValueError, match="time_limit"):
        lamina.render(s, time_limit=-1)
    with pytest.raises(TypeError):
        lamina.render(s, spp="many")
    with pytest.raises(TypeError):
        lamina.render("scene.toml")
    with pytest.raises(TypeError, match="callable"):
        lamina.render(s, spp=1, progress=42)
    with pytest.raises(ValueError, match="accel must be 'lamina' or 'embree'"):
        lamina.render(s, spp=1, accel="optix")


def test_accel_picks_the_engine(small_dict):
    s = lamina.Scene.from_dict(small_dict)
    a = lamina.render(s, spp=2, seed=3, accel="lamina")
    assert np.array_equal(a, lamina.render(s, spp=2, seed=3))
    try:
        b = lamina.render(s, spp=2, seed=3, accel="embree")
    except lamina.RenderError as e:
        # A build without Embree says which feature it lacks.
        assert "`embree` feature" in str(e)
    else:
        assert np.abs(b - a).mean() <= 1e-3 * a.mean()


def test_time_limit_returns_a_partial_image(small_dict):
    small_dict["film"].update(width=320, height=240)
    s = lamina.Scene.from_dict(small_dict)
    t = time.perf_counter()
    img, st = lamina.render(s, spp=100000, time_limit=0.5, stats=True)
    assert time.perf_counter() - t < 10
    assert st["stopped_early"] and 1 <= st["spp"] < 100000
    assert np.all(np.isfinite(img)) and img.mean() > 0


def test_the_gil_is_released_while_rendering(small_dict):
    small_dict["film"].update(width=320, height=240)
    s = lamina.Scene.from_dict(small_dict)
    ticks = []
    done = threading.Event()

    def tick():
        while not done.is_set():
            ticks.append(time.perf_counter())
            time.sleep(0.01)

    th = threading.Thread(target=tick)
    th.start()
    try:
        lamina.render(s, spp=16)
    finally:
        done.set()
        th.join()
    assert len(ticks) > 5, "another Python thread did not run during the render"


CANCEL = textwrap.dedent(
    """
    import os, signal, sys, threading, time
    # Python turns SIGINT into KeyboardInterrupt only where it was not ignored at start-up,
    # and a job started in the background by a non-interactive shell (a CI runner's
    # `cmd &`, nohup) starts with it ignored: what is tested is lamina's response to
    # KeyboardInterrupt, so the child asks for it whatever it inherited.
    signal.signal(signal.SIGINT, signal.default_int_handler)
    import lamina
    s = lamina.load_scene(sys.argv[1], overrides={"film.width": 1280, "film.height": 960})
    t0 = None
    def interrupt():
        global t0
        t0 = time.perf_counter()
        os.kill(os.getpid(), signal.SIGINT)
    threading.Timer(1.0, interrupt).start()
    try:
        lamina.render(s, spp=100000)
        print("NOT INTERRUPTED")
    except KeyboardInterrupt:
        print(f"INTERRUPTED {time.perf_counter() - t0:.3f}")
    """
)


def test_ctrl_c_cancels_within_a_second(scene_file):
    r = subprocess.run(
        [sys.executable, "-c", CANCEL, str(scene_file)],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert r.returncode == 0, r.stderr
    word, secs = r.stdout.split()
    assert word == "INTERRUPTED", r.stdout
    assert float(secs) < 1.0, f"took {secs} s to stop"


def test_render_gpu(small_dict):
    s = lamina.Scene.from_dict(small_dict)
    try:
        img, warnings = lamina.render_gpu(s, warnings=True)
    except lamina.RenderError as e:
        if "no GPU adapter" in str(e) and not os.environ.get("LAMINA_GPU_REQUIRED"):
            pytest.skip(str(e))
        raise
    assert img.shape == (32, 48, 3) and img.dtype == np.float32
    assert np.all(np.isfinite(img)) and img.mean() > 0.01
    assert isinstance(warnings, list)
    # It agrees with the path tracer in the mean (the GPU path is an approximation).
    cpu = lamina.render(s, spp=64)
    assert abs(img.mean() - cpu.mean()) / cpu.mean() < 0.35
    # Level of detail: every leaf, or thinned out; a leaf area out of range is an error.
    full = lamina.render_gpu(s, lod=0)
    assert full.shape == img.shape and abs(full.mean() - img.mean()) < 0.02 * img.mean()
    with pytest.raises(lamina.RenderError, match="lod=-1"):
        lamina.render_gpu(s, lod=-1)


def test_read_exr_errors(tmp_path):
    with pytest.raises(lamina.RenderError, match="cannot read"):
        lamina.read_exr(tmp_path / "nope.exr")
    (tmp_path / "bad.exr").write_bytes(b"not an exr")
    with pytest.raises(lamina.RenderError, match="cannot read"):
        lamina.read_exr(tmp_path / "bad.exr")


def test_write_image_matches_the_cli_and_keeps_foreign_files(cli, scene_file, tmp_path):
    s = lamina.load_scene(scene_file, overrides={"film.width": 64, "film.height": 48})
    f = tmp_path / "small.toml"
    f.write_text(s.to_toml().replace('"cards.csv"', f'"{tmp_path / "cards.csv"}"'))
    cli("render", f, "--spp", 2, "-q", "-o", tmp_path / "cli.png")
    img = lamina.render(s, spp=2)
    lamina.write_image(tmp_path / "py.png", img, s)
    assert (tmp_path / "py.png").read_bytes() == (tmp_path / "cli.png").read_bytes()
    lamina.write_image(tmp_path / "py.exr", img)
    back, _ = lamina.read_exr(tmp_path / "py.exr")
    assert np.array_equal(back, img)
    # Rewriting lamina's own file is fine; a user's file is kept unless force=True.
    lamina.write_image(tmp_path / "py.png", img, s)
    user = tmp_path / "mine.png"
    user.write_bytes(b"my own picture")
    with pytest.raises(lamina.RenderError, match="mine.png"):
        lamina.write_image(user, img, s)
    assert user.read_bytes() == b"my own picture"
    with pytest.raises(ValueError, match=r"\(H, W, 3\)"):
        lamina.write_image(tmp_path / "x.png", img[..., :2])
    with pytest.raises(ValueError, match="tonemap"):
        lamina.write_image(tmp_path / "x.png", img, tonemap="fancy")
    with pytest.raises(lamina.RenderError):
        lamina.write_image(tmp_path / "x.jpg2", img)
    assert not (tmp_path / "x.png").exists()
