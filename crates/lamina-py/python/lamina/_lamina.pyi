"""Type stubs of lamina's native module (import ``lamina``, not ``lamina._lamina``)."""

from os import PathLike
from typing import Any, Callable, Dict, List, Mapping, Optional, Sequence, Tuple, Union

import numpy as np
import numpy.typing as npt

_Path = Union[str, PathLike]
_Vec = Union[Sequence[float], npt.ArrayLike]

__version__: str

class SceneError(ValueError):
    """A scene could not be loaded or edited."""

    file: Optional[str]
    """The file at fault; ``None`` for a scene given as a dict."""
    line: Optional[int]
    """1-based line in ``file``, when known."""
    key: Optional[str]
    """The dotted key at fault (``film.width``, ``material[1].roughness``), when known."""
    message: str
    """What was wrong, in words."""

class LeafError(ValueError):
    """A leaf, its maps, its pigments or a spectrum is invalid."""

class RenderError(RuntimeError):
    """A render failed (an invalid option, no GPU adapter, an unreadable EXR, ...)."""

class Scene:
    """A scene ready to render; see ``load_scene`` and ``Scene.from_dict``."""

    @staticmethod
    def from_dict(d: Mapping[str, Any], base_dir: Optional[_Path] = None) -> "Scene":
        """A scene from a dict with the keys of a scene file (lists of dicts for the
        ``[[light]]``, ``[[material]]`` and ``[[object]]`` tables). Relative paths start at
        ``base_dir`` (default: the current directory). Raises ``SceneError``."""
    @staticmethod
    def load(path: _Path, overrides: Optional[Mapping[str, Any]] = None) -> "Scene":
        """The same as ``lamina.load_scene``."""
    def to_toml(self) -> str:
        """The TOML text the scene was read from, with the edits made since."""
    @property
    def path(self) -> Optional[str]:
        """The scene file, or ``None`` for a dict scene."""
    @property
    def width(self) -> int:
        """Image width, pixels."""
    @property
    def height(self) -> int:
        """Image height, pixels."""
    @property
    def spp(self) -> int:
        """``film.spp``: samples per pixel when ``render`` gets no ``spp``."""
    @property
    def bands(self) -> Optional[List[str]]:
        """Names of the film's spectral bands (the render's channels), or ``None`` (RGB)."""
    @property
    def camera(self) -> Dict[str, Any]:
        """``position``, ``look_at``, ``up`` (m), ``fov`` (horizontal, degrees),
        ``aperture_radius``, ``focus_distance`` (m), as loaded."""
    @property
    def film(self) -> Dict[str, Any]:
        """The ``[film]`` table as written, with ``width``, ``height``, ``spp``,
        ``exposure`` as loaded."""
    @property
    def lights(self) -> List[Dict[str, Any]]:
        """Each light's ``type`` and keys, as loaded (a sun's ``direction`` points toward
        the sun)."""
    @property
    def materials(self) -> List[str]:
        """All material names: the ``[[material]]`` tables, then imported ones."""
    def material(self, name: str) -> Dict[str, Any]:
        """The ``[[material]]`` table named ``name`` as written (with the edits)."""
    @property
    def sun_direction(self) -> List[float]:
        """Unit vector toward the scene's first sun; settable."""
    @sun_direction.setter
    def sun_direction(self, value: _Vec) -> None: ...
    def set_camera(self, **kwargs: Any) -> None:
        """Sets ``[camera]`` keys, checked as in a file."""
    def set_film(self, **kwargs: Any) -> None:
        """Sets ``[film]`` keys, checked as in a file."""
    def set_light(self, index: int, /, **kwargs: Any) -> None:
        """Sets keys of the ``index``-th ``[[light]]``."""
    def set_material(self, material: str, /, **kwargs: Any) -> None:
        """Sets keys of the ``[[material]]`` named ``material``; only it is rebuilt."""
    def set(self, key: str, value: Any) -> None:
        """Sets one dotted key (``"light[0].irradiance"``), as ``lamina render --set``.
        Object keys are refused: they change the geometry."""
    def update(self, edits: Mapping[str, Any]) -> None:
        """Sets several dotted keys at once, all or none."""
    def copy(self) -> "Scene":
        """An independent copy (geometry shared until edited)."""
    def stats(self) -> Dict[str, int]:
        """``triangles``, ``prototypes``, ``instances``, ``lights``, ``materials``."""

class Leaf:
    """A leaf material and its BSDF (local frame: +z the adaxial normal)."""

    @staticmethod
    def species(name: str, seed: int = 1, resolution: int = 256) -> "Leaf":
        """A built-in species' procedural leaf (beech, maple, oak, birch, ivy, grass,
        willow)."""
    @staticmethod
    def load(path: _Path) -> "Leaf":
        """A leaf folder (with ``leaf.toml``) or a ``leaf.toml``."""
    @staticmethod
    def from_dict(d: Mapping[str, Any], base_dir: Optional[_Path] = None) -> "Leaf":
        """A leaf from the keys of a ``leaf.toml``: ``params``, ``maps``, ``pigments``."""
    def eval(
        self, wo: _Vec, wi: _Vec, uv: Optional[_Vec] = None
    ) -> npt.NDArray[np.float64]:
        """``f(wo, wi) |cos θi|`` per RGB channel, ``(N, 3)`` (or ``(3,)``); ``wo``, ``wi``
        ``(N, 3)`` or ``(3,)``, ``uv`` ``(N, 2)`` or ``(2,)``."""
    def pdf(self, wo: _Vec, wi: _Vec, uv: Optional[_Vec] = None) -> Union[float, npt.NDArray[np.float64]]:
        """Solid-angle density of ``sample`` returning ``wi``, ``(N,)`` (or a float)."""
    def sample(
        self, wo: _Vec, u: _Vec, uv: Optional[_Vec] = None
    ) -> Tuple[npt.NDArray[np.float64], npt.NDArray[np.float64], Union[float, npt.NDArray[np.float64]]]:
        """``(wi, f, pdf)`` drawn from uniform numbers ``u`` in [0, 1) (``(N, 3)``); rows
        without energy have ``pdf == 0``."""
    def albedo(
        self,
        theta: float = 8.0,
        side: str = "adaxial",
        wavelengths: Optional[_Vec] = None,
        samples: int = 65536,
    ) -> Tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]:
        """Directional-hemispherical ``(R, T)`` at incidence ``theta`` (degrees) on
        ``side``: ``(3,)`` RGB arrays, or one value per wavelength (nm) for a pigment
        leaf."""
    def opaque(self, uv: Tuple[float, float]) -> bool:
        """Whether the alpha matte keeps the leaf at ``uv``."""
    @property
    def is_pigment(self) -> bool:
        """Whether the colours come from PROSPECT pigments."""
    @property
    def pigments(self) -> Optional[Dict[str, Any]]:
        """The PROSPECT inputs of a pigment leaf."""

def load_scene(path: _Path, overrides: Optional[Mapping[str, Any]] = None) -> Scene:
    """Loads a scene file; ``overrides`` sets dotted keys first (``{"film.spp": 64}``)."""

def render(
    scene: Scene,
    *,
    spp: Optional[int] = None,
    seed: int = 0,
    threads: Optional[int] = None,
    time_limit: Optional[float] = None,
    progress: Optional[Callable[[Dict[str, Any]], Any]] = None,
    stats: bool = False,
    accel: str = "lamina",
) -> Any:
    """The native render; use ``lamina.render``."""

def render_gpu(scene: Scene, *, warnings: bool = False, lod: float = 1.0) -> Any:
    """The real-time GPU approximation: ``(H, W, 3)`` float32 linear radiance, or
    ``(image, warnings)``. ``lod``: the leaf area in pixels below which a plant's leaves
    thin out, their area kept (stochastic simplification); 0 draws every leaf. Raises
    ``RenderError`` without a Vulkan adapter, or for a ``lod`` outside 0-10000."""

def measure(
    scene: Scene,
    *,
    seed: int = 0,
    threads: Optional[int] = None,
    sample_scale: Optional[float] = None,
) -> List[Dict[str, Any]]:
    """Runs the scene's ``[[sensor]]`` tables (``brf``, ``irradiance``, ``absorbed``,
    ``fisheye``) and returns one dict per sensor: ``name``, ``type``, ``channels``,
    ``channel``, ``samples``, ``seconds``, ``rays`` and the sensor's values with their
    standard errors as NumPy arrays (one column per channel: R, G, B or the film's bands).
    The same values ``lamina render`` writes to the sensors' files for the same seed."""

def prospect(
    *,
    n: Optional[float] = None,
    cab: Optional[float] = None,
    car: Optional[float] = None,
    anth: Optional[float] = None,
    cbrown: Optional[float] = None,
    cw: Optional[float] = None,
    cm: Optional[float] = None,
    prot: Optional[float] = None,
    cbc: Optional[float] = None,
    alpha: Optional[float] = None,
    model: str = "d",
) -> Tuple[npt.NDArray[np.float64], npt.NDArray[np.float64], npt.NDArray[np.float64]]:
    """PROSPECT-D or -PRO: ``(wavelength_nm, R, T)`` over 400-2500 nm at 1 nm."""

def fit_leaf(
    wavelengths: _Vec, r: _Vec, t: Optional[_Vec] = None, band_weight: float = 8.0
) -> Dict[str, Any]:
    """PROSPECT-D fitted to a measured R (and T): ``pigments``, ``model_r``, ``model_t``,
    ``rmse_r``, ``rmse_t``, ``iterations``, ``wavelengths``. ``band_weight``: how much the
    five band means weigh (0: a per-nanometre fit alone)."""

def read_exr(path: _Path) -> Tuple[npt.NDArray[np.float32], List[str]]:
    """An EXR's first layer as ``(H, W, C)`` float32 and its channel names."""

def write_image(
    path: _Path,
    image: npt.ArrayLike,
    scene: Optional[Scene] = None,
    *,
    exposure: float = 0.0,
    tonemap: str = "aces",
    force: bool = False,
) -> None:
    """Writes ``(H, W, 3)`` linear RGB as ``.exr`` or ``.png`` (the scene film's exposure
    and tone map), atomically; a file lamina did not write is kept unless ``force``."""
