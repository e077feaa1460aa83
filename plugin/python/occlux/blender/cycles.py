"""Blender's side of the Cycles check: the Occlux scene built as a Blender scene (the volume from
the exported ``value`` grid, the material and world of :mod:`.material`, the camera and lights
the core resolved, Cycles' settings), the check that Blender's camera is Occlux's, and the
renders at many seeds whose spread is Cycles' standard error."""

from __future__ import annotations

import contextlib
import math
import os
import sys
import tempfile
import time
from collections.abc import Callable, Generator, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from occlux._occlux import OccluxError, Scene, Volume

from .common import (
    CYCLES_FIRST_SEED,
    DEFAULT_SEEDS,
    OCCLUX_SEED,
    HarnessError,
    check_estimator,
    effective_options,
)
from .images import read_channels
from .material import PREFIX, colour_and_strength, make_material, make_world
from .scene import CameraSpec, LightSpec, SceneSpec, load_scene

SEQUENCE_LENGTH = 4096
"""Cycles' sample count for every render, of which each render draws its own subset
(``use_sample_subset``). Measured on the tooth under a sun (single scattering, 32 renders per
point): renders of 4 / 16 / 32 / 64 samples were biased by +1.8 / +0.75 / +0.34 / <0.1 % in
the mean over the volume's pixels, while subsets of 2 or 4 samples of a 4096-sample sequence
matched Occlux within 0.2 % (1 sigma). Cycles' sampling pattern depends on the sample count."""


def bpy_module():
    """Blender's Python module (the bpy wheel, or Blender itself)."""
    try:
        import bpy
    except ImportError as e:
        raise HarnessError(
            "the Cycles harness needs Blender 5 as a Python module: pip install bpy==5.0.1"
        ) from e
    return bpy


def placed_value_grid(vdb_path: str | os.PathLike[str], spec: SceneSpec) -> Path:
    """``vdb_path``, checked: its ``value`` grid (read by the core) must lie on the lattice
    where the scene places the volume; refused otherwise.

    The core reads a sparse grid as the box of its active voxels: the grid must have the
    scene's spacing, and that box must start on a voxel of the scene's volume and end inside
    it. Occlux writes fog volumes padded by one voxel repeating the border (src/export/vdb.rs):
    Occlux clamps trilinear samples to the border voxels up to the faces of the volume's box
    and has no medium beyond, while Cycles interpolates towards the grid's background (0) over
    the voxel past the last stored one; with the padding Cycles' samples inside the box are
    Occlux's, and the material's box mask removes what lies beyond (see
    :func:`.material.make_material`). So the file is rendered as it is."""
    path = Path(vdb_path)
    try:
        grid = Volume.load(path, grid="value")
    except OccluxError as e:
        raise HarnessError(f"{path}: no readable `value` grid ({e})") from e
    spacing = np.asarray(spec.spacing)
    offset = (np.asarray(grid.origin) - np.asarray(spec.origin)) / spacing
    start = np.round(offset).astype(int)
    dims = np.asarray(spec.dims)
    placed = (
        np.allclose(grid.spacing, spacing, rtol=1e-5)
        and np.allclose(offset, start, atol=1e-3)
        and (start >= 0).all()
        and (start + np.asarray(grid.dims) <= dims).all()
    )
    if not placed:
        raise HarnessError(
            f"{path}: its grid is not placed as {spec.label} places the volume (voxels of "
            f"size {grid.spacing} from {grid.origin}, not of size {spec.spacing} on the "
            f"{spec.dims} voxels from {spec.origin}): export it again"
        )
    return path


def _free_persistent_data(scene) -> None:
    """Frees the render engine that ``use_persistent_data`` keeps alive after a render
    (switching it off frees it). That engine holds a depsgraph of the scene's data: removing
    the data while it lives leaves it pointing at freed blocks, and Blender crashes in the next
    node-tree or depsgraph update (seen in CI: a segfault in the next build's material)."""
    if scene.render.use_persistent_data:
        scene.render.use_persistent_data = False


def remove_built() -> None:
    """Removes the data a previous build made: every scene, object, volume, material, world,
    camera and lamp named with PREFIX (and nothing else of the session's)."""
    bpy = bpy_module()
    for scene in bpy.data.scenes:
        if scene.name.startswith(PREFIX):
            _free_persistent_data(scene)
    for collection in (
        bpy.data.scenes,
        bpy.data.objects,
        bpy.data.volumes,
        bpy.data.materials,
        bpy.data.worlds,
        bpy.data.cameras,
        bpy.data.lights,
    ):
        for block in [b for b in collection if b.name.startswith(PREFIX)]:
            collection.remove(block)


def _camera_object(bpy, cam: CameraSpec):
    """Blender's camera looks down its local -Z with local +Y up. A perspective camera gets the
    core's vertical field of view (sensor fit VERTICAL), an orthographic one its scale along the
    larger image side (sensor fit AUTO)."""
    from mathutils import Matrix

    data = bpy.data.cameras.new(f"{PREFIX}-camera")
    if cam.perspective:
        data.type = "PERSP"
        data.sensor_fit = "VERTICAL"
        data.angle_y = cam.fov_y
    else:
        data.type = "ORTHO"
        data.sensor_fit = "AUTO"
        data.ortho_scale = cam.ortho_scale
    data.shift_x = data.shift_y = 0.0
    # Rays start at the eye (Occlux's start there too), and nothing is cut off behind.
    data.clip_start = 1e-4
    data.clip_end = 1e8
    obj = bpy.data.objects.new(f"{PREFIX}-camera", data)
    back = tuple(-c for c in cam.forward)
    rows = [[cam.right[i], cam.up[i], back[i], cam.position[i]] for i in range(3)]
    obj.matrix_world = Matrix([*rows, [0.0, 0.0, 0.0, 1.0]])
    return obj


def _light_objects(bpy, lights: Sequence[LightSpec]) -> list:
    """Suns (strength = irradiance in W/m^2, angle 0, pointing from the light) and point lights
    (power = 4 pi times the radiant intensity, radius 0)."""
    from mathutils import Vector

    objects = []
    for i, light in enumerate(lights):
        colour, strength = colour_and_strength(light.rgb)
        if light.kind == "directional":
            data = bpy.data.lights.new(f"{PREFIX}-light{i}", "SUN")
            data.angle = 0.0
            data.energy = strength
        else:
            data = bpy.data.lights.new(f"{PREFIX}-light{i}", "POINT")
            data.shadow_soft_size = 0.0
            data.use_soft_falloff = False
            data.energy = 4.0 * math.pi * strength
        data.color = colour[:3]
        data.use_shadow = True
        obj = bpy.data.objects.new(f"{PREFIX}-light{i}", data)
        if light.kind == "directional":
            # A sun shines along its local -Z: +Z points at the light.
            obj.rotation_mode = "QUATERNION"
            obj.rotation_quaternion = Vector(light.vector).to_track_quat("Z", "Y")
        else:
            obj.location = light.vector
        objects.append(obj)
    return objects


def linear_exr_output(scene) -> None:
    """Sets `scene`'s output to the full image as a linear 32-bit RGB EXR: opaque film, the
    film filter (EEVEE's and Workbench's; Cycles has its own) at 0.01 pixel, no border, no
    motion blur, square pixels, and the Standard view transform with no look, exposure or gamma,
    so that the file holds the renderer's radiance as it is. Shared by Cycles and the EEVEE peer
    of ``occlux chart`` (``occlux_lab.peers.eevee``)."""
    render = scene.render
    render.film_transparent = False
    render.filter_size = 0.01
    render.resolution_percentage = 100
    render.pixel_aspect_x = render.pixel_aspect_y = 1.0
    render.use_border = False
    render.use_motion_blur = False
    render.image_settings.media_type = "IMAGE"
    render.image_settings.file_format = "OPEN_EXR"
    render.image_settings.color_depth = "32"
    render.image_settings.color_mode = "RGB"
    scene.view_settings.view_transform = "Standard"
    scene.view_settings.look = "None"
    scene.view_settings.exposure = 0.0
    scene.view_settings.gamma = 1.0


def cycles_settings(scene, bounces: int) -> None:
    """Sets `scene` up for unbiased, unfiltered, undenoised path tracing on the CPU with
    `bounces` volume bounces, into a linear 32-bit EXR."""
    scene.render.engine = "CYCLES"
    linear_exr_output(scene)
    c = scene.cycles
    c.device = "CPU"
    c.samples = SEQUENCE_LENGTH
    c.seed = CYCLES_FIRST_SEED
    c.use_animated_seed = False
    c.use_denoising = False
    c.use_adaptive_sampling = False
    # Occlux's camera rays go through pixel centres. Cycles' BOX filter is one pixel wide
    # whatever its width (measured: it box-filters the image); Blackman-Harris at Cycles'
    # minimum width, 0.01 pixel, puts every sample within 0.005 pixel of the centre.
    c.pixel_filter_type = "BLACKMAN_HARRIS"
    c.filter_width = 0.01
    c.sample_clamp_direct = 0.0
    c.sample_clamp_indirect = 0.0  # the factory 10 biases multiple scattering
    c.light_sampling_threshold = 0.0
    c.use_guiding = False
    c.volume_bounces = bounces
    c.max_bounces = max(bounces + 1, 12)
    c.diffuse_bounces = c.glossy_bounces = c.transmission_bounces = 0
    c.transparent_max_bounces = 1024
    c.volume_biased = False  # null scattering, unbiased
    c.volume_step_rate = 1.0
    c.volume_max_steps = 1024


def build_scene(
    scene: str | os.PathLike[str] | Scene,
    vdb_path: str | os.PathLike[str],
    estimator: str,
    bounces: int = 0,
    g: float = 0.0,
    *,
    volume: Volume | None = None,
):
    """Builds the Occlux scene (a scene file, or an ``occlux.Scene``) as a new Blender scene set
    up to render ``estimator`` with Cycles and returns it (a ``bpy.types.Scene``; render it with
    :func:`render_scene`). The volume is the ``value`` grid of ``vdb_path`` (from
    ``occlux.export``, or ``occlux.write_vdb`` of the scene's volume). ``bounces`` is Cycles'
    volume bounces for "multiple" (0 for the others); ``g`` the Henyey-Greenstein asymmetry for
    "single" and "multiple" ("ambient" is isotropic). ``volume`` is the scene's volume if the
    caller has settled the same ``occlux.Scene`` (else the scene is settled here:
    :func:`.scene.load_scene`). Data made by a previous build is removed."""
    built, _ = build_blender_scene(scene, vdb_path, estimator, bounces, g, volume=volume)
    cycles_settings(built, effective_options(estimator, bounces, g)[0])
    return built


def build_blender_scene(
    scene: str | os.PathLike[str] | Scene,
    vdb_path: str | os.PathLike[str],
    estimator: str,
    bounces: int = 0,
    g: float = 0.0,
    *,
    volume: Volume | None = None,
) -> tuple[Any, SceneSpec]:
    """:func:`build_scene` without a render engine's settings: the volume, material, camera,
    lights and world of ``estimator``, at the camera's resolution. Returns the Blender scene and
    the :class:`.scene.SceneSpec` it was built from (for a renderer that needs more of the scene,
    such as EEVEE's volume range, ``occlux_lab.peers.eevee``)."""
    check_estimator(estimator)
    if not -1.0 < g < 1.0:
        raise HarnessError(f"g must be in (-1, 1), got {g}")
    bounces, g = effective_options(estimator, bounces, g)
    spec = load_scene(scene, volume)
    bpy = bpy_module()
    remove_built()
    grid_path = placed_value_grid(vdb_path, spec)
    scene = bpy.data.scenes.new(f"{PREFIX}-scene")
    volume = bpy.data.volumes.new(f"{PREFIX}-volume")
    volume.filepath = str(grid_path.resolve())
    if not volume.grids.load():
        raise HarnessError(f"{grid_path}: Blender cannot read it: {volume.grids.error_message}")
    volume.render.precision = "FULL"
    volume.render.space = "OBJECT"
    volume.render.clipping = 0.0
    volume.materials.append(make_material(bpy, spec.points, spec.box, g, bounces))
    obj = bpy.data.objects.new(f"{PREFIX}-volume", volume)
    scene.collection.objects.link(obj)
    camera = _camera_object(bpy, spec.camera)
    scene.collection.objects.link(camera)
    scene.camera = camera
    scene.render.resolution_x = spec.camera.width
    scene.render.resolution_y = spec.camera.height
    if estimator == "ambient":
        environment, lights = spec.ambient, []
    elif estimator == "single":
        environment, lights = (0.0, 0.0, 0.0), list(spec.lights)
    else:
        environment, lights = spec.ambient, list(spec.lights)
    scene.world = make_world(bpy, environment, spec.background)
    for light in _light_objects(bpy, lights):
        scene.collection.objects.link(light)
    return scene, spec


def camera_frustum(scene) -> dict[str, Any]:
    """The Blender camera as Occlux's EXR header states a camera: eye, forward and up vectors
    and the half extents of the image plane (tangents of the half angles, or half sizes), as
    Blender itself computes them for the render's resolution."""
    cam = scene.camera
    render = scene.render
    matrix = cam.calc_matrix_camera(
        scene.view_layers[0].depsgraph, x=render.resolution_x, y=render.resolution_y
    )
    world = cam.matrix_world
    return {
        "position": list(world.translation),
        "forward": list(-world.col[2].xyz.normalized()),
        "up": list(world.col[1].xyz.normalized()),
        "half_extent": [1.0 / matrix[0][0], 1.0 / matrix[1][1]],
        "perspective": cam.data.type == "PERSP",
    }


def check_camera(scene, occlux_camera: dict[str, Any], tolerance: float = 1e-4) -> None:
    """Raises HarnessError unless Blender's camera is the one Occlux rendered with (the
    ``occlux/camera`` header of its EXR, or the ``camera`` of :meth:`occlux.Scene.describe`):
    its eye, forward and up vectors and the half extents of its image plane, as Blender computes
    them for the render's resolution."""
    ours = camera_frustum(scene)
    theirs = {
        "position": occlux_camera["position"],
        "forward": occlux_camera["forward"],
        "up": occlux_camera["up"],
        "half_extent": occlux_camera["half_extent"],
    }
    projection = occlux_camera["projection"]  # {"type": "perspective", "fov_y": ...}
    if ours["perspective"] != (projection["type"] == "perspective"):
        raise HarnessError(f"projection differs: Blender {ours}, Occlux {occlux_camera}")
    for key, want in theirs.items():
        got = np.asarray(ours[key])
        if not np.allclose(got, want, rtol=tolerance, atol=tolerance):
            raise HarnessError(f"camera {key} differs: Blender {got.tolist()}, Occlux {want}")


@dataclass
class CyclesImage:
    """Per-pixel mean and standard error of K Cycles renders, (height, width, 3) float64, row 0
    at the top; the seeds used and the wall time of all renders."""

    mean: np.ndarray
    stderr: np.ndarray
    seeds: list[int]
    spp_per_seed: int
    seconds: float


@contextlib.contextmanager
def quiet_stdout():
    """Blender logs every image it saves on the process's standard output (file descriptor 1,
    beneath Python's sys.stdout); this keeps those lines out of the harness's report."""
    sys.stdout.flush()
    saved = os.dup(1)
    try:
        with open(os.devnull, "w") as null:
            os.dup2(null.fileno(), 1)
            yield
    finally:
        os.dup2(saved, 1)
        os.close(saved)


def render_still(scene, path: Path | str, what: str) -> float:
    """Renders ``scene`` into the file ``path`` (its output settings as they are), quietly, and
    returns the seconds the render and the write took; a render that does not finish raises
    HarnessError naming ``what`` was rendered."""
    bpy = bpy_module()
    scene.render.filepath = str(path)
    started = time.perf_counter()
    with quiet_stdout():
        result = bpy.ops.render.render(write_still=True, scene=scene.name)
    seconds = time.perf_counter() - started
    if result != {"FINISHED"}:
        raise HarnessError(f"{what} to {path} ended with {result}")
    return seconds


@dataclass(frozen=True)
class SeedDone:
    """Progress of :func:`render_seeds`: ``done`` of ``total`` renders finished."""

    done: int
    total: int


def render_seeds(
    scene, spp: int, seeds: int = DEFAULT_SEEDS
) -> Generator[SeedDone, None, CyclesImage]:
    """:func:`render_scene` one render at a time: a generator that yields after each seed's
    render and returns the CyclesImage, so that a caller on Blender's main thread (which every
    render needs) can show progress and stop between renders. Closing it early frees the
    render engine and the renders' files."""
    if seeds < 2:
        raise HarnessError(f"seeds must be at least 2 (for a standard error), got {seeds}")
    per_seed = spp // seeds
    if per_seed < 1:
        raise HarnessError(f"spp ({spp}) must be at least the number of seeds ({seeds})")
    c = scene.cycles
    c.samples = max(SEQUENCE_LENGTH, per_seed * seeds)
    c.use_sample_subset = True
    c.sample_subset_length = per_seed
    seed_list = [CYCLES_FIRST_SEED + k for k in range(seeds)]
    assert OCCLUX_SEED not in seed_list
    total = total_sq = 0.0
    started = time.perf_counter()
    # Renders at other seeds reuse the first one's volume octree; freed after the last one.
    scene.render.use_persistent_data = True
    try:
        with tempfile.TemporaryDirectory(prefix="occlux-cycles-") as tmp:
            for k, seed in enumerate(seed_list):
                c.seed = seed
                c.sample_offset = k * per_seed
                render_still(scene, Path(tmp) / f"seed{seed}.exr", f"Cycles render at seed {seed}")
                channels, _ = read_channels(scene.render.filepath)
                rgb = np.stack([channels[ch] for ch in "RGB"], axis=-1).astype(np.float64)
                total = total + rgb
                total_sq = total_sq + rgb * rgb
                yield SeedDone(k + 1, seeds)
    finally:
        _free_persistent_data(scene)
    seconds = time.perf_counter() - started
    mean = total / seeds
    variance = np.maximum(total_sq - seeds * mean * mean, 0.0) / (seeds - 1)
    return CyclesImage(mean, np.sqrt(variance / seeds), seed_list, per_seed, seconds)


def render_scene(
    scene,
    spp: int,
    seeds: int = DEFAULT_SEEDS,
    progress: Callable[[int, int], object] | None = None,
) -> CyclesImage:
    """Renders a built scene ``seeds`` times with distinct seeds (none equal to Occlux's), each
    with ``spp // seeds`` samples, and returns the per-pixel mean and standard error;
    ``progress(done, total)`` after each render.

    Each render is a subset (its own samples) of one SEQUENCE_LENGTH-sample sequence: Cycles
    renders whose sample count is small are biased (see SEQUENCE_LENGTH)."""
    renders = render_seeds(scene, spp, seeds)
    while True:
        try:
            step = next(renders)
        except StopIteration as end:
            return end.value
        if progress is not None:
            progress(step.done, step.total)


def render_cycles(
    scene_path: str | os.PathLike[str],
    vdb_path: str | os.PathLike[str],
    estimator: str,
    spp: int,
    seeds: int = DEFAULT_SEEDS,
    bounces: int = 0,
    g: float = 0.0,
    progress: Callable[[int, int], object] | None = None,
) -> CyclesImage:
    """:func:`build_scene` then :func:`render_scene`."""
    scene = build_scene(scene_path, vdb_path, estimator, bounces, g)
    return render_scene(scene, spp, seeds, progress)
