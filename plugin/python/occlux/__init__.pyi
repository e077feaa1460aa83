"""Type stubs of the ``occlux`` package (the native module ``occlux._occlux``)."""

from collections.abc import Callable, Collection, Sequence
from os import PathLike
from typing import Any, Literal

import numpy as np
import numpy.typing as npt

from occlux.batch import SeriesError as SeriesError
from occlux.batch import SeriesResult as SeriesResult
from occlux.batch import series as series

__version__: str
PHANTOMS: list[str]
"""Names that :meth:`Volume.phantom` accepts."""
PRESETS: list[str]
"""Names that :meth:`Classification.preset` accepts."""

_Path = str | PathLike[str]
_Triple = tuple[float, float, float]
_Device = Literal["auto", "gpu", "cpu"]
_Units = Literal["normalized", "raw", "hu"]

class OccluxError(Exception):
    """An error reported by the Occlux core. The message is the core's, verbatim: it names the
    file, field or parameter at fault and the expected form."""

class Volume:
    """A dense scalar volume in world units: voxel ``(i, j, k)`` is ``values[k, j, i]`` and has
    its centre at ``origin + (i, j, k) * spacing``. Immutable."""

    def __init__(
        self,
        values: npt.NDArray[np.number],
        spacing: Sequence[float] = (1.0, 1.0, 1.0),
        origin: Sequence[float] = (0.0, 0.0, 0.0),
    ) -> None:
        """Builds a volume from an array of shape ``(nz, ny, nx)`` and any real dtype, converted
        to float32 with one copy. Raises TypeError/ValueError for a non-array, a non-real dtype or
        another number of dimensions, and OccluxError for NaN or infinite values, non-positive
        spacing or a non-finite origin."""

    @staticmethod
    def load(path: _Path, grid: str | None = None) -> Volume:
        """Loads a volume file (.nrrd, .nhdr, .nii, .nii.gz, .vdb, .npy); ``grid`` picks a VDB
        grid (default: the only or first float grid)."""

    @staticmethod
    def phantom(name: str, size: int = 64) -> Volume:
        """A built-in phantom (see :data:`PHANTOMS`) filling [-1, 1]^3 with ``size``^3 voxels."""

    @property
    def dims(self) -> tuple[int, int, int]:
        """Voxels along x, y, z: ``(nx, ny, nz)``."""

    @property
    def spacing(self) -> _Triple:
        """Distance between voxel centres along x, y, z, in world units."""

    @property
    def origin(self) -> _Triple:
        """World position of the centre of voxel (0, 0, 0)."""

    @property
    def bounds(self) -> tuple[_Triple, _Triple]:
        """World-space bounding box of the voxels' cells: ``((min x, y, z), (max x, y, z))``."""

    @property
    def value_range(self) -> tuple[float, float]:
        """Smallest and largest value."""

    @property
    def values(self) -> npt.NDArray[np.float32]:
        """Read-only float32 array of shape ``(nz, ny, nx)`` viewing the volume's memory (no
        copy; the array keeps the volume alive)."""

    def robust_window(self) -> dict[str, Any]:
        """The robust window of the values, on which normalised transfer functions (the presets)
        read 0 and 1, as ``occlux info`` prints it: ``lo`` and ``hi``, ``cut`` (the value above
        which wrapped negative numbers are classified as ``lo``; None when there are none),
        ``background`` (the centre of the most common value band) and the shares of the sampled
        voxels ``above`` the window's top and ``wrapped`` (cut away); ``points``, the ramp
        ``occlux info --suggest`` suggests on it, as ``(value, sigma_t, albedo, emission)`` in the
        file's values."""

    def histogram(self, lo: float, hi: float, bins: int = 64) -> npt.NDArray[np.uint64]:
        """Voxels in ``bins`` equal bins over ``[lo, hi]``, binned as
        ``numpy.histogram(values, bins, range=(lo, hi))`` bins them in float64; values outside
        are not counted. Counted in parallel over the volume's own memory (no copy). Raises
        OccluxError naming ``histogram.bins`` (1 to 65536) or ``histogram.range`` (finite
        lo < hi)."""

class Classification:
    """Maps the value (and, for 2D presets, the gradient magnitude) to extinction sigma_t per
    world unit, an RGB single-scattering albedo and an RGB emission. Immutable."""

    @staticmethod
    def preset(
        name: str, density_scale: float = 1.0, units: _Units = "normalized"
    ) -> Classification:
        """A built-in classification (see :data:`PRESETS`). ``units`` says how its value
        positions are read: "normalized" (on the robust window of the volume's values: 0 near
        the background, 1 at the top of the object's values) or "hu" (the CT presets' forms in
        Hounsfield units). ``density_scale`` multiplies sigma_t."""

    @staticmethod
    def from_points(
        points: Sequence[tuple[float, float, _Triple, _Triple]],
        units: _Units = "normalized",
        density_scale: float = 1.0,
    ) -> Classification:
        """A piecewise-linear 1D transfer function through control points
        ``(value, sigma_t, (r, g, b) albedo, (r, g, b) emission)``."""

    @property
    def units(self) -> _Units: ...
    @property
    def density_scale(self) -> float: ...
    @property
    def points(
        self,
    ) -> list[tuple[float, float, tuple[float, float, float], tuple[float, float, float]]] | None:
        """Control points ``(value, sigma_t, albedo, emission)`` of a 1D transfer function
        (before ``density_scale``); None for a 2D one."""
    def raw_points(
        self, volume: Volume
    ) -> list[tuple[float, float, tuple[float, float, float], tuple[float, float, float]]] | None:
        """The control points on ``volume``'s raw values, sorted, ``density_scale`` applied: the
        function Occlux's table holds for that volume; None for a 2D transfer function."""
    def extinction(self, volume: Volume) -> Volume:
        """Extinction (sigma_t per world unit) at every voxel centre of ``volume``, on the same
        grid: the ``density`` grid that :func:`export` writes."""

class Scene:
    """A scene: the volume source, classification, camera and image size, lights, background
    and rendering method (the TOML scene file of the CLI)."""

    @staticmethod
    def load(path: _Path) -> Scene:
        """Reads a TOML scene file; relative volume paths are resolved against its folder."""

    @staticmethod
    def from_toml(text: str, base_dir: _Path = ".") -> Scene:
        """Parses TOML scene text; relative volume paths are resolved against ``base_dir``."""

    @staticmethod
    def from_dict(tree: dict[str, Any], base_dir: _Path = ".") -> Scene:
        """Builds a scene from the scene file's tree as Python data (the TOML file's sections
        and keys: ``volume``, ``classification``, ``camera``, ``lights``, ``background``,
        ``render``), validated as a file is."""

    def describe(self) -> dict[str, Any]:
        """The scene as the core resolved it: ``volume`` (source, fit, centre),
        ``classification``, ``camera`` (position, forward, right, up, ``projection`` with
        ``type`` and ``fov_y`` in radians or ``scale``, width, height, half_extent),
        ``lighting`` (``lights``, ``background``) and ``method`` (``method`` and every
        parameter)."""

    def settle(self) -> tuple[Volume, list[str]]:
        """Loads (or generates) the scene's volume and settles what depends on the data, as
        ``occlux render`` does: Hounsfield presets when the file says its values are HU, the
        classification's window on the values, the content centre and the framed camera. The
        scene is updated; returns the volume and the notices, one line each."""

    def load_volume(self) -> Volume:
        """Loads (or generates) the scene's volume and places it in the world (fit, centre)."""

    classification: Classification
    """The classification; assign a :class:`Classification` to replace it."""

    @property
    def width(self) -> int: ...
    @property
    def height(self) -> int: ...
    def set_size(self, width: int, height: int) -> None:
        """Changes the image size, keeping the camera's position, orientation and vertical field
        of view (or orthographic scale): the same aspect ratio gives the same view."""

    @property
    def background(self) -> _Triple:
        """Background radiance (r, g, b) seen where rays leave the volume."""

class RenderResult:
    """A rendered image. Immutable: ``beauty`` and ``depth`` are read-only views."""

    @property
    def beauty(self) -> npt.NDArray[np.float32]:
        """Linear RGBA, shape ``(height, width, 4)``, row 0 at the top; the background is
        composited in and alpha is the volume's opacity."""

    @property
    def depth(self) -> npt.NDArray[np.float32]:
        """Distance from the eye to where the ray's opacity crosses 0.5 (1e10 where it never
        does), shape ``(height, width)``."""

    @property
    def occlusion(self) -> npt.NDArray[np.float32] | None:
        """Directional occlusion shading's occlusion layer, made for compositing, shape
        ``(height, width, 2)``: ``[..., 0]`` is P, each sample's lit fraction of the ambient
        light weighted by its contribution to the pixel (the transmittance in front of it times
        its opacity, as its colour is composited) and summed along the ray; ``[..., 1]`` is A,
        the coverage (the sum of those weights, equal to ``beauty[..., 3]``). So
        ``0 <= P <= A``, ``P == A`` where nothing occludes and ``P == A == 0`` where the ray
        meets nothing; ``P / A`` is the mean occlusion of what the pixel shows. Shade another
        render of the same view by ``render * (1 - strength * (A - P))`` (1 where A is 0). The
        EXR holds the same as channels ``occlusion.V`` (P) and ``occlusion.A`` (A). ``None`` for
        methods that compute none."""

    @property
    def shadow(self) -> npt.NDArray[np.float32] | None:
        """IPSVI's (and half-angle slicing's) shadow layer, shape ``(height, width, 2)``:
        ``[..., 0]`` is P, the lights' transmittance at each sample (the lights weighted by
        their irradiance) weighted by the sample's contribution and summed along the ray;
        ``[..., 1]`` is the coverage A, as for ``occlusion`` (EXR channels ``shadow.V`` and
        ``shadow.A``). ``None`` for methods that compute none."""

    @property
    def plan(self) -> str | None:
        """For a scene with ``method = "auto"``: what the planner chose, as JSON text
        (``method``, ``chosen``, ``budget``, ``truth``, ``predicted_error``,
        ``predicted_seconds``), also written into the EXR header as ``occlux/plan``; ``None``
        for a scene with a fixed method."""

    @property
    def width(self) -> int: ...
    @property
    def height(self) -> int: ...
    @property
    def device(self) -> str:
        """Where it ran: the GPU adapter, e.g. "llvmpipe (LLVM 15, 256 bits), Vulkan", or "cpu"."""

def render(
    scene: Scene,
    volume: Volume | None = None,
    device: _Device = "auto",
    progress: Callable[[int, int], object] | None = None,
) -> RenderResult:
    """Renders ``scene`` with its own volume, or with ``volume``, on ``device``: "auto" (a GPU
    adapter if one opens, else the CPU with a RuntimeWarning), "gpu" (or OccluxError) or "cpu".
    ``progress(done, total)`` is called as rows finish; returning ``False`` from it cancels the
    work (OccluxError "cancelled"); an exception it raises is re-raised once the render is done.
    The GIL is released while it loads and renders."""

def write_exr(path: _Path, result: RenderResult, scene: Scene, float32: bool = False) -> None:
    """Writes a multilayer OpenEXR atomically: layers ``beauty`` (R, G, B, A; float16 unless
    ``float32``), ``depth`` (Z, float32) and the result's ``occlusion`` or ``shadow`` if it has
    one (``V``: the factor premultiplied by coverage, ``A``: the coverage), with the scene's
    camera, method and lighting as text attributes ``occlux/*`` in the header."""

def write_exr_layers(
    path: _Path,
    layers: dict[str, npt.ArrayLike],
    metadata: dict[str, str] | None = None,
    float32: bool = True,
) -> None:
    """Writes ``{name: array}`` (in the dict's order) as one multilayer OpenEXR, atomically: an
    array of shape (height, width) is a layer with channel ``Y``; one of shape (height, width,
    c) has channels Y (c = 1), R, G, B (3) or R, G, B, A (4), stored as ``layer.channel``, row 0
    at the top. ``metadata`` becomes text attributes of the header. Samples are float32, or
    float16 unless ``float32``; NaN or infinite samples are an OccluxError and nothing is
    written."""

def write_png(path: _Path, rgb: npt.NDArray[np.uint8]) -> None:
    """Writes an 8-bit picture, shape (height, width, 3) and dtype uint8, row 0 at the top, as
    an sRGB PNG, atomically; the codes are stored as they are."""

def image_error(
    image: npt.ArrayLike,
    reference: npt.ArrayLike,
    background: float,
    stderr: npt.ArrayLike | None = None,
) -> dict[str, float]:
    """DESIGN.md's error of ``image`` against ``reference`` (shape (height, width, 3 or 4),
    linear RGB; alpha ignored) over the volume's pixels, those where the reference's grey
    differs from ``background`` by more than 0.5 % of it: ``pixels``, ``rel_rmse`` (RMSE of
    the RGB difference / the reference's mean there), ``bias`` (mean difference / that mean)
    and ``noise`` (the RMS of ``stderr`` / that mean; 0 without it)."""

def write_error_map(
    path: _Path, image: npt.ArrayLike, reference: npt.ArrayLike, background: float
) -> float:
    """Writes a PNG of where ``image`` differs from ``reference`` (as for ``image_error``):
    blue where the image is darker, white where equal, red where brighter, over the volume's
    pixels (others mid grey), at least 256 pixels wide, with a colour key below; atomically.
    Returns the key's range (relative to the reference's mean)."""

def write_text(path: _Path, text: str) -> None:
    """Writes ``text`` (UTF-8) to ``path``, atomically."""

def write_reference(
    out_dir: _Path,
    result: ReferenceResult,
    scene: Scene,
    stem: str = "reference",
    estimator: Literal["ambient", "cone", "single", "multiple"] = "single",
    seed: int = 1,
    bounces: int = 8,
    g: float = 0.0,
    aperture_deg: float = 30.0,
    exposure: float = 1.0,
) -> list[str]:
    """Writes :func:`reference`'s ``result`` (made with these ``estimator``, ``seed``,
    ``bounces``, ``g`` and ``aperture_deg``) as ``occlux reference`` does: ``STEM.exr`` (float32
    layers ``beauty`` and ``stderr``; ``occlux/camera``, ``occlux/method``, ``occlux/lighting``
    and ``occlux/reference`` as JSON in the header) and ``STEM.png`` (a preview of the mean) in
    ``out_dir``; returns the paths."""

def write_vdb(
    path: _Path,
    grids: dict[str, Volume],
    compression: Literal["zip", "none"] = "zip",
    half: bool | Collection[str] = False,
) -> None:
    """Writes ``{name: Volume}`` as float grids of one OpenVDB file, atomically: sparse (voxels
    equal to 0 are inactive) fog volumes with each volume's spacing and origin as the grid
    transform; ``half`` stores values as float16 (11 significant bits): True for every grid, or
    the names of the grids to store so, the others float32. A grid whose voxels are all 0, or a
    value a half float cannot hold (|v| > 65504) in a half grid, is an error."""

class ReferenceResult:
    """A Monte Carlo reference. Immutable; the arrays are read-only views of its memory."""

    @property
    def mean(self) -> npt.NDArray[np.float32]:
        """(height, width, 4): RGB radiance and the fraction of camera paths that met the
        volume."""
    @property
    def stderr(self) -> npt.NDArray[np.float32]:
        """(height, width, 3): the standard error of ``mean``'s RGB."""
    @property
    def spp(self) -> int: ...

def reference(
    scene: Scene,
    estimator: Literal["ambient", "cone", "single", "multiple"] = "single",
    spp: int = 64,
    seed: int = 1,
    bounces: int = 8,
    g: float = 0.0,
    aperture_deg: float = 30.0,
    volume: Volume | None = None,
    progress: Callable[[int, int], object] | None = None,
) -> ReferenceResult:
    """A Monte Carlo reference of ``scene`` on the CPU (see ``occlux reference``): unbiased,
    seeded and deterministic, with per-pixel standard errors. The GIL is released."""

def stage_description(
    scene: Scene,
    volume: Volume,
    vdb_file: str,
    grids: Sequence[str],
    frames: Sequence[str] | None = None,
) -> str:
    """The USD stage for ``volume``'s grids ``grids`` in ``vdb_file`` (relative to the stage)
    with ``scene``'s camera and lights, as JSON for :mod:`occlux.usd`; with ``frames`` (VDB
    files), a series' stage whose fields read ``frames[i]`` at time code ``i + 1``."""

def export(
    scene: Scene,
    out_dir: _Path,
    stem: str = "scene",
    volume: Volume | None = None,
    device: _Device = "auto",
    compression: Literal["zip", "none"] = "zip",
    half: bool = False,
    float32: bool = False,
    exposure: float = 1.0,
    progress: Callable[[int, int], object] | None = None,
) -> list[str]:
    """What ``occlux export`` does: renders ``scene`` and writes ``STEM.exr``, ``.png``,
    ``.vdb`` (grids ``density`` and ``value``) and ``.usda`` into ``out_dir``; returns the
    paths."""

def ao_volume(
    scene: Scene,
    method: Literal[
        "ordinates", "cdf", "gauss", "gauss-exact", "penner", "exact", "sweep", "sweep-physical"
    ] = "ordinates",
    radius: int = 10,
    field: Literal["extinction", "value"] = "extinction",
    variance: bool = False,
    device: _Device = "auto",
    volume: Volume | None = None,
    progress: Callable[[int, int], object] | None = None,
    iso: float | None = None,
    gamma: float = 2.0,
    octant_intensities: Sequence[float] | None = None,
    alpha: float = 1.0,
    combined: bool = False,
    octants: bool = False,
    convention: Literal["unoccluded", "raw"] = "unoccluded",
    directions: int = 64,
) -> dict[str, Volume]:
    """What ``occlux ao`` computes: the AO volume of ``scene``'s classified volume,
    ``{"ao": openness}`` (1 = unoccluded) on the volume's grid, ready for :func:`write_vdb`;
    plus ``"ao_variance"`` when ``variance`` is true (VAO). ``exact`` counts voxels (slow,
    CPU). ``sweep`` is occlusion sweeping: the AO of the iso-surface ``iso`` of the raw values
    (without it, of the classified extinction at half its maximum) after ``gamma``, lit from
    the eight octants with ``octant_intensities`` (``ao_oct`` order: bit 0 -x, bit 1 -y,
    bit 2 -z), ``alpha`` < 1 for a translucent surface, ``combined`` for the octants' plain
    mean; it adds ``"sdf"`` (signed distance, negative inside; a level set in
    :func:`write_vdb`) and, with ``octants``, ``"ao_oct0"``..``"ao_oct7"``.
    ``ordinates`` (the default) is the visibility, the mean transmittance over all directions,
    along straight paths in ``directions`` directions (discrete ordinates); ``sweep-physical``
    the same by a lattice walk (about 19 % too much optical depth).
    ``convention``: ``"unoccluded"`` (1 in empty space and on an open flat surface, as Blender
    shades; VAO: min(1, 2F) of the paper's openness F) or ``"raw"`` (VAO's estimators only: F
    itself, 1/2 in empty space and on a flat interface)."""

def bake(
    scene: Scene,
    directions: int = 64,
    multiple: bool = True,
    g: float = 0.0,
    device: _Device = "auto",
    volume: Volume | None = None,
    progress: Callable[[int, int], object] | None = None,
) -> dict[str, Volume]:
    """What ``occlux bake`` computes: the light of ``scene`` baked into grids a renderer shades
    with, without tracing shadows, each per unit strength of its light: ``"ao"`` (the ambient
    visibility by ``directions`` discrete ordinates; with ``multiple`` also ``"ao_multiple_r"``,
    ``"_g"``, ``"_b"``, uniform white ambient light's multiply scattered light per unit
    radiance), then per sun or lamp ``i`` of the scene's lights (in order, ambient lights
    skipped) ``"light{i}"`` (the irradiance reaching each voxel
    per unit strength: the transmittance for a sun, transmittance / r^2 for a lamp) and, with
    ``multiple``, ``"light{i}_multiple_r"``, ``"_g"``, ``"_b"`` (its multiply scattered light
    per unit strength, Henyey-Greenstein ``g``, on the solver's coarser grid), ready for
    :func:`write_vdb`. Emission per unit length sigma_s (world x (ao + ao_multiple) + sum_i
    strength_i colour_i (light{i} / 4 pi + light{i}_multiple)) renders the baked light."""

def methods() -> list[dict[str, Any]]:
    """The rendering methods a scene's ``render.method`` can name (the core's registry): each
    with ``name``, ``summary``, ``module``, ``shaders``, ``lights`` (those it renders),
    ``layers``, ``grids``, ``chart`` (the settings ``occlux chart`` measures), ``for_lights``
    (the lights its model is for: the chart and the planner weigh it only under one) and
    ``params`` (``key``, ``doc``, ``type``, ``default``, and ``range`` or ``options``)."""
