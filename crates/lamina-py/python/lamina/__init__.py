"""lamina: plant leaves and whole plants, rendered and measured.

Scenes are loaded from TOML files (``load_scene``) or built from dicts with the same keys
(``Scene.from_dict``), edited from Python and rendered to NumPy arrays (``render``,
``render_gpu``), and measured through their sensors (``measure``: BRF, irradiance,
absorbed power, fisheye gap fractions, with standard errors). Leaf optics (``Leaf``: BSDF evaluation and sampling over arrays of
directions, directional-hemispherical albedo), PROSPECT leaf spectra (``prospect``) and
their inversion (``fit_leaf``) use the same code as the renderer and the ``lamina`` CLI.

Units: lengths in metres; radiance in W m^-2 sr^-1 (linear Rec.709 RGB), or band-mean
spectral radiance per nm for spectral bands; angles in degrees; wavelengths in nm.
"""

from __future__ import annotations

import sys as _sys
from typing import Any, Callable, Optional, Union

from ._lamina import (  # noqa: F401  (re-exported)
    Leaf,
    LeafError,
    RenderError,
    Scene,
    SceneError,
    __version__,
    fit_leaf,
    load_scene,
    measure,
    prospect,
    read_exr,
    render_gpu,
    write_image,
)
from ._lamina import render as _render

__all__ = [
    "Leaf",
    "LeafError",
    "RenderError",
    "Scene",
    "SceneError",
    "__version__",
    "fit_leaf",
    "load_scene",
    "measure",
    "prospect",
    "read_exr",
    "render",
    "render_gpu",
    "write_image",
]


class _Bar:
    """Progress as a tqdm bar when tqdm is installed, else one line per pass on stderr."""

    def __init__(self) -> None:
        self._bar = None
        self._group = -1
        try:
            import tqdm  # type: ignore

            self._tqdm = tqdm.tqdm
        except ImportError:
            self._tqdm = None

    def __call__(self, p: dict) -> None:
        label = "lamina" if p["groups"] == 1 else f"lamina bands {p['group'] + 1}/{p['groups']}"
        if self._tqdm is not None:
            if self._bar is None or p["group"] != self._group:
                if self._bar is not None:
                    self._bar.close()
                self._bar = self._tqdm(total=p["spp_total"], unit="spp", desc=label)
                self._group = p["group"]
            self._bar.update(p["spp_done"] - self._bar.n)
            if p["spp_done"] >= p["spp_total"]:
                self._bar.close()
                self._bar = None
        else:
            print(
                f"{label}: pass {p['passes_done']}/{p['passes_total']}, "
                f"{p['spp_done']}/{p['spp_total']} spp, {p['elapsed']:.2f} s",
                file=_sys.stderr,
            )

    def close(self) -> None:
        if self._bar is not None:
            self._bar.close()
            self._bar = None


def render(
    scene: Scene,
    *,
    spp: Optional[int] = None,
    seed: int = 0,
    threads: Optional[int] = None,
    time_limit: Optional[float] = None,
    progress: Union[bool, Callable[[dict], Any], None] = None,
    stats: bool = False,
    accel: str = "lamina",
):
    """Render ``scene`` with the offline path tracer.

    Returns linear radiance as a float32 array of shape ``(height, width, 3)`` (linear
    Rec.709 RGB, W m^-2 sr^-1, top row first), or ``(height, width, K)`` with one channel
    per band (band-mean spectral radiance, W m^-2 sr^-1 nm^-1) when the scene's film has
    ``bands``. The same scene, seed and spp give the same array as ``lamina render
    --seed`` writes to an EXR, bit for bit.

    spp: samples per pixel (default ``film.spp``). seed: random seed. threads: worker
    threads (default: all cores). time_limit: seconds; the render stops at a pass boundary
    and returns what is done. progress: ``True`` for a progress bar (tqdm if installed),
    or a callable receiving a dict (``spp_done``, ``spp_total``, ``passes_done``,
    ``passes_total``, ``elapsed``, ``group``, ``groups``) after every pass; an exception it
    raises cancels the render and propagates. Passes add 16 samples per pixel each; with a
    progress display or a time limit the first ones add 1, 1, 2, 4 and 8 (a little slower;
    the same array either way). stats: also return a dict of counters
    (``elapsed``, ``rays``, ``samples``, ...). accel: the ray-casting engine, ``"lamina"``
    (its own) or ``"embree"`` (Intel Embree 3, for comparison, in a lamina built with the
    ``embree`` feature; ``lamina.RenderError`` naming the feature otherwise).

    The GIL is released while rendering; Ctrl-C cancels the render and raises
    KeyboardInterrupt within a second.
    """
    bar = None
    callback = progress
    if progress is True:
        bar = _Bar()
        callback = bar
    elif progress is False:
        callback = None
    try:
        return _render(
            scene,
            spp=spp,
            seed=seed,
            threads=threads,
            time_limit=time_limit,
            progress=callback,
            stats=stats,
            accel=accel,
        )
    finally:
        if bar is not None:
            bar.close()
