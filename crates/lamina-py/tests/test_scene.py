"""Scenes from files and dicts: the loader's keys, checks and messages; edits."""

import numpy as np
import pytest

import lamina


def test_load_scene_reads_the_file(scene_file):
    s = lamina.load_scene(scene_file)
    assert (s.width, s.height, s.spp) == (480, 360, 64)
    assert s.materials == ["leaf", "soil"]
    assert s.camera["fov"] == 45.0
    assert s.camera["position"] == [0.0, 0.35, 0.9]
    assert s.lights[0]["type"] == "sun"
    assert s.path == scene_file
    assert s.bands is None
    assert "480x360" in repr(s)


def test_overrides_set_keys_before_reading(scene_file):
    s = lamina.load_scene(scene_file, overrides={"film.spp": 8, "film.width": 100})
    assert (s.spp, s.width) == (8, 100)


def test_file_errors_name_file_line_and_key(scene_file):
    text = scene_file.read_text().replace("width = 480", "width = -3")
    scene_file.write_text(text)
    with pytest.raises(lamina.SceneError) as e:
        lamina.load_scene(scene_file)
    err = e.value
    assert isinstance(err, ValueError)
    assert err.file == str(scene_file)
    assert err.line == 10
    assert err.key == "film.width"
    assert "film.width" in str(err) and str(scene_file) in str(err)


def test_missing_file_is_a_scene_error(tmp_path):
    with pytest.raises(lamina.SceneError) as e:
        lamina.load_scene(tmp_path / "nope.toml")
    assert e.value.file == str(tmp_path / "nope.toml")
    assert "No such file" in str(e.value)


def test_from_dict_equals_the_same_scene_as_a_file(small_dict, tmp_path):
    s = lamina.Scene.from_dict(small_dict)
    assert s.path is None
    assert s.materials == ["leaf", "soil"]
    # Its TOML text loads as a file to the same scene.
    f = tmp_path / "same.toml"
    f.write_text(s.to_toml())
    t = lamina.load_scene(f)
    assert t.camera == s.camera and t.lights == s.lights and t.film == s.film
    a = lamina.render(s, spp=2)
    b = lamina.render(t, spp=2)
    assert np.array_equal(a, b)


def test_numpy_values_are_accepted(small_dict):
    small_dict["camera"]["position"] = np.array([0.0, 0.35, 0.9])
    small_dict["film"]["width"] = np.int64(40)
    s = lamina.Scene.from_dict(small_dict)
    assert s.width == 40


@pytest.mark.parametrize(
    "edit, key, words",
    [
        (lambda d: d["film"].update(widht=3), "film.widht", "did you mean `width`"),
        (lambda d: d["film"].update(width=0), "film.width", "[1, 16384]"),
        (lambda d: d["film"].update(width=None), "film.width", "None"),
        (lambda d: d["film"].update(width="wide"), "film.width", ""),
        (lambda d: d["camera"].update(position=[0, 1]), "camera.position", ""),
        (lambda d: d["camera"].update(position=[0, float("nan"), 1]), "camera.position", ""),
        (lambda d: d["light"][0].update(irradiance=object()), "light[0].irradiance", "object"),
        (lambda d: d["material"][0].update(species="palm"), "material[0].species", "palm"),
        (lambda d: d["object"][0].update(material="nothing"), "object[0].material", "nothing"),
        (lambda d: d.update(lights=[]), "lights", ""),
    ],
)
def test_dict_errors_name_the_key(small_dict, edit, key, words):
    edit(small_dict)
    with pytest.raises(lamina.SceneError) as e:
        lamina.Scene.from_dict(small_dict)
    err = e.value
    assert err.file is None and err.line is None
    assert err.key is not None and err.key.startswith(key), (err.key, str(err))
    assert words in str(err)
    assert str(err).startswith("scene dict: ")


def test_a_missing_map_names_its_file(small_dict, tmp_path):
    small_dict["material"][1]["reflectance_map"] = "no_such_map.png"
    with pytest.raises(lamina.SceneError) as e:
        lamina.Scene.from_dict(small_dict, base_dir=tmp_path)
    assert "no_such_map.png" in str(e.value)
    assert e.value.key == "material[1].reflectance_map"


def test_not_a_dict():
    with pytest.raises(lamina.SceneError):
        lamina.Scene.from_dict([1, 2, 3])
    with pytest.raises(TypeError):
        lamina.load_scene(42)


def test_edits_change_the_render_and_keep_the_geometry(small_dict):
    s = lamina.Scene.from_dict(small_dict)
    before = lamina.render(s, spp=2)
    s.set_camera(fov=30)
    s.set_film(width=40, height=30)
    s.sun_direction = [0, 1, 0]
    s.set_material("soil", reflectance=[0.5, 0.5, 0.5])
    s.set_light(0, irradiance=[2, 2, 2])
    s.set("sky.radiance", [0.1, 0.1, 0.1])
    assert s.camera["fov"] == 30.0 and (s.width, s.height) == (40, 30)
    assert s.sun_direction == [0.0, 1.0, 0.0]
    assert s.material("soil")["reflectance"] == [0.5, 0.5, 0.5]
    assert s.lights[0]["irradiance"] == [2.0, 2.0, 2.0]
    after = lamina.render(s, spp=2)
    assert after.shape == (30, 40, 3)
    assert after.mean() != pytest.approx(before.mean())
    # The edited scene equals the same scene loaded with the edits from the start.
    fresh = lamina.Scene.from_dict(
        {**small_dict, "camera": {**small_dict["camera"], "fov": 30}}
    )
    fresh.update(
        {
            "film.width": 40,
            "film.height": 30,
            "light[0].direction": [0, 1, 0],
            "light[0].irradiance": [2, 2, 2],
            "material[1].reflectance": [0.5, 0.5, 0.5],
            "sky.radiance": [0.1, 0.1, 0.1],
        }
    )
    assert np.array_equal(lamina.render(fresh, spp=2), after)


def test_bad_edits_raise_and_change_nothing(small_dict):
    s = lamina.Scene.from_dict(small_dict)
    cam = s.camera
    with pytest.raises(lamina.SceneError) as e:
        s.set_camera(fov=500)
    assert e.value.key == "camera.fov"
    with pytest.raises(lamina.SceneError) as e:
        s.set_camera(fvo=30)
    assert "fvo" in str(e.value)
    with pytest.raises(lamina.SceneError) as e:
        s.set("object[0].material", "soil")
    assert "geometry" in str(e.value)
    with pytest.raises(lamina.SceneError) as e:
        s.set_material("soil", name="dirt")
    assert "renamed" in str(e.value)
    with pytest.raises(KeyError):
        s.set_material("nothing", reflectance=[1, 1, 1])
    with pytest.raises(IndexError):
        s.set_light(5, irradiance=[1, 1, 1])
    with pytest.raises(lamina.SceneError):
        s.update({"camera.fov": 20, "film.width": -1})
    assert s.camera == cam
    assert s.width == 48


def test_copy_is_independent(small_dict):
    s = lamina.Scene.from_dict(small_dict)
    t = s.copy()
    t.set_camera(fov=20)
    assert s.camera["fov"] == 45.0 and t.camera["fov"] == 20.0


def test_bands_scene(small_dict):
    small_dict["film"]["bands"] = [
        {"name": "B4", "center": 665, "width": 30},
        {"name": "B8", "center": 842, "width": 115},
        {"name": "B3", "center": 560, "width": 35},
        {"name": "B2", "center": 490, "width": 65},
    ]
    s = lamina.Scene.from_dict(small_dict)
    assert s.bands == ["B4", "B8", "B3", "B2"]
    img = lamina.render(s, spp=2)
    assert img.shape == (32, 48, 4) and img.dtype == np.float32
    assert np.all(np.isfinite(img)) and img.min() >= 0
