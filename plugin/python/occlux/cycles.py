"""Cross-check of Occlux's Monte Carlo references against Blender's Cycles.

Given an Occlux scene, this module builds the same scene in Blender 5 (as a Python module or
inside Blender): the volume from the VDB that ``occlux export`` writes, its ``value`` grid mapped
through the scene's 1D transfer function onto a Principled Volume, the camera, the lights and the
world of one of Occlux's estimators; renders it with Cycles at several seeds; and compares the
result with ``occlux reference``'s image pixel by pixel, in units of the combined standard error.
The conventions it relies on, and how each was verified, are in docs/cycles-mapping.md.

From a shell (what ``occlux check-cycles`` runs)::

    python -m occlux.cycles examples/engine.toml --estimator single --spp 256 --out check/

From Python::

    import occlux.cycles as oc

    cycles = oc.render_cycles("engine.toml", "out/engine.vdb", "single", spp=256, seeds=16)
    report = oc.compare(oc.read_reference("out/engine-single.exr"), cycles.mean, cycles.stderr)
    print(report.table())
"""

from __future__ import annotations

import argparse
import contextlib
import importlib
import json
import math
import os
import shutil
import site
import subprocess
import sys
import tempfile
import time
import tomllib
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import numpy as np

from occlux._occlux import OccluxError, Scene

ESTIMATORS = ("ambient", "single", "multiple")
"""The Occlux estimators that Cycles can reproduce (the DOS cone phase function has no Cycles
counterpart)."""

MAX_RAMP_STOPS = 32
"""Blender's Color Ramp holds at most 32 stops: transfer functions with more points are refused."""

MASK_ALPHA = 0.01
"""Pixels whose Occlux alpha (fraction of camera paths that interact) exceeds this are compared."""

DEFAULT_SEEDS = 32
"""Cycles renders per comparison: the per-pixel standard error is their spread, so it needs a
dozen or more (with K renders the z scores follow Student's t with about K - 1 degrees of freedom
where Cycles' noise dominates)."""

OCCLUX_SEED = 1
"""The seed the harness gives ``occlux reference``; no Cycles render uses it."""

CYCLES_FIRST_SEED = 1000
"""Cycles renders use seeds CYCLES_FIRST_SEED, CYCLES_FIRST_SEED + 1, ..."""

SEQUENCE_LENGTH = 4096
"""Cycles' sample count for every render, of which each render draws its own subset
(``use_sample_subset``). Measured on the tooth under a sun (single scattering, 32 renders per
point): renders of 4 / 16 / 32 / 64 samples were biased by +1.8 / +0.75 / +0.34 / <0.1 % in
the mean over the volume's pixels, while subsets of 2 or 4 samples of a 4096-sample sequence
matched Occlux within 0.2 % (1 sigma). Cycles' sampling pattern depends on the sample count."""

NOISE_FLOOR = 0.12
"""z adds NOISE_FLOOR * (Occlux's mean radiance over the mask) / sqrt(Occlux's spp) to the
standard errors, in quadrature: a tenth of the standard error of a pixel whose samples spread as
much as the image is bright, so typical pixels' z barely change (RMS z by < 1 %). It is there
for deep shadow: where a pixel's few lit samples may all be missed (Occlux's ratio tracking
plays Russian roulette below transmittance 0.05), its standard error reads 0 or far too low;
without the floor, pixels at 1e-3 of the image's brightness gave |z| of 10 to 70 (engine, sun,
256-1024 spp), and the sums over such pixels agreed within their errors. The missed part
shrinks as 1/spp, faster than the floor."""

Z_CLIP = 4.0
"""The error map's colour scale spans z in [-Z_CLIP, Z_CLIP]."""

# Agreement: z scores of unbiased estimates of the same image are ~N(0, 1).
RMS_Z_RANGE = (0.8, 1.25)
MAX_ABS_MEAN_Z = 0.2
MAX_FRACTION_OVER_3 = 0.01

# Exit status of the command line when the check ran and the images disagree (2: it could not
# run; 0: they agree).
EXIT_DISAGREE = 3

# Names of the Blender data the harness creates (and removes before building again).
PREFIX = "occlux-cycles"

Rgb = tuple[float, float, float]


class HarnessError(OccluxError):
    """A scene that cannot be mapped onto Cycles, or a step of the cross-check that failed; the
    message names the file and the problem."""


# ---- The scene, as the harness needs it ----


@dataclass(frozen=True)
class TfPoint:
    """A transfer-function control point in the volume's raw values, density scale applied."""

    value: float
    sigma_t: float
    albedo: Rgb
    emission: Rgb


@dataclass(frozen=True)
class CameraSpec:
    """The scene's camera (src/camera.rs): an orthonormal frame and a projection.

    ``lens_mm``/``sensor_mm`` are set when the scene gives them (Blender's sensor fit AUTO);
    otherwise ``fov_y`` (radians, vertical) for perspective or ``ortho_scale`` (extent along the
    larger image side) for orthographic cameras."""

    position: Rgb
    forward: Rgb
    up: Rgb
    right: Rgb
    perspective: bool
    fov_y: float | None
    lens_mm: float | None
    sensor_mm: float | None
    ortho_scale: float | None
    width: int
    height: int


@dataclass(frozen=True)
class LightSpec:
    """A directional light (``vector`` = unit direction towards it, ``rgb`` = irradiance) or a
    point light (``vector`` = position, ``rgb`` = radiant intensity)."""

    kind: str
    vector: Rgb
    rgb: Rgb


@dataclass(frozen=True)
class SceneSpec:
    """What the harness reads from a scene: the transfer function, camera and lights, and the
    volume's grid (voxel counts, the centre of voxel (0, 0, 0), spacing, and the box of its
    cells, where Occlux's medium ends)."""

    path: Path
    dims: tuple[int, int, int]
    origin: Rgb
    spacing: Rgb
    box: tuple[Rgb, Rgb]
    points: tuple[TfPoint, ...]
    camera: CameraSpec
    ambient: Rgb
    background: Rgb
    lights: tuple[LightSpec, ...]


def _rgb(value: Any, key: str, path: Path) -> Rgb:
    """A scene colour: a grey level or an [r, g, b] list."""
    if isinstance(value, int | float):
        return (float(value),) * 3
    if isinstance(value, list) and len(value) == 3:
        return (float(value[0]), float(value[1]), float(value[2]))
    raise HarnessError(f"{path}: {key} must be a number or [r, g, b], got {value!r}")


def _unit(v: Sequence[float]) -> np.ndarray:
    a = np.asarray(v, dtype=np.float64)
    return a / np.linalg.norm(a)


def _triple(a: np.ndarray) -> Rgb:
    return (float(a[0]), float(a[1]), float(a[2]))


def _camera(section: dict[str, Any]) -> CameraSpec:
    """The camera of the scene file, with the defaults and semantics of src/scene.rs."""
    position = np.asarray(section["position"], dtype=np.float64)
    target = np.asarray(section.get("target", [0.0, 0.0, 0.0]), dtype=np.float64)
    forward = _unit(target - position)
    right = _unit(np.cross(forward, section.get("up", [0.0, 0.0, 1.0])))
    up = np.cross(right, forward)
    perspective = section.get("projection", "perspective") == "perspective"
    lens = section.get("lens_mm")
    fov_deg = section.get("fov_deg", 40.0 if lens is None else None)
    return CameraSpec(
        position=_triple(position),
        forward=_triple(forward),
        up=_triple(up),
        right=_triple(right),
        perspective=perspective,
        fov_y=math.radians(fov_deg) if perspective and fov_deg is not None else None,
        lens_mm=float(lens) if perspective and lens is not None else None,
        sensor_mm=float(section.get("sensor_mm", 36.0)) if lens is not None else None,
        ortho_scale=None if perspective else float(section.get("ortho_scale", 2.0)),
        width=int(section.get("width", 512)),
        height=int(section.get("height", 512)),
    )


def _tf_points(scene: Scene, value_range: tuple[float, float], path: Path) -> tuple[TfPoint, ...]:
    """Control points in raw values, sorted, with the density scale applied to sigma_t."""
    classification = scene.classification
    points = classification.points
    if points is None:
        raise HarnessError(
            f"{path}: the classification is a 2D transfer function (value x gradient "
            "magnitude); the Cycles mapping needs a 1D one"
        )
    if classification.units == "normalized":
        vmin, vmax = value_range
        # As the core bakes its table: a constant volume still gets a unit-wide axis.
        vmax = vmax if vmax > vmin else vmin + 1.0

        def to_raw(x: float) -> float:
            return vmin + x * (vmax - vmin)
    else:

        def to_raw(x: float) -> float:
            return x

    raw = [
        TfPoint(
            value=to_raw(float(value)),
            sigma_t=float(sigma_t) * classification.density_scale,
            albedo=tuple(float(a) for a in albedo),
            emission=tuple(float(e) for e in emission),
        )
        for value, sigma_t, albedo, emission in points
    ]
    if len(raw) > MAX_RAMP_STOPS:
        raise HarnessError(
            f"{path}: the transfer function has {len(raw)} control points; Blender's Color Ramp "
            f"holds at most {MAX_RAMP_STOPS}"
        )
    if max(p.sigma_t for p in raw) <= 0.0:
        raise HarnessError(f"{path}: the transfer function has sigma_t = 0 everywhere")
    return tuple(sorted(raw, key=lambda p: p.value))


def load_scene(scene_path: str | os.PathLike[str]) -> SceneSpec:
    """Reads an Occlux scene file (validated by the core first) into what Cycles needs."""
    path = Path(scene_path)
    scene = Scene.load(path)  # the core's validation, with its messages
    with path.open("rb") as f:
        toml = tomllib.load(f)
    ambient = np.zeros(3)
    lights = []
    for i, light in enumerate(toml.get("lights", [])):
        kind = light["type"]
        if kind == "ambient":
            ambient += _rgb(light["radiance"], f"lights[{i}].radiance", path)
        elif kind == "directional":
            rgb = _rgb(light["irradiance"], f"lights[{i}].irradiance", path)
            lights.append(LightSpec(kind, _triple(_unit(light["direction"])), rgb))
        else:
            rgb = _rgb(light["intensity"], f"lights[{i}].intensity", path)
            lights.append(LightSpec(kind, _triple(np.asarray(light["position"], float)), rgb))
    volume = scene.load_volume()
    return SceneSpec(
        path=path,
        dims=volume.dims,
        origin=volume.origin,
        spacing=volume.spacing,
        box=volume.bounds,
        points=_tf_points(scene, volume.value_range, path),
        camera=_camera(toml["camera"]),
        ambient=_triple(ambient),
        background=scene.background,
        lights=tuple(lights),
    )


# ---- Blender ----


def _bpy():
    """Blender's Python module (the bpy wheel, or Blender itself)."""
    try:
        import bpy
    except ImportError as e:
        raise HarnessError(
            "the Cycles harness needs Blender 5 as a Python module: pip install bpy==5.0.1"
        ) from e
    return bpy


def padded_value_grid(vdb_path: str | os.PathLike[str], spec: SceneSpec) -> Path:
    """Writes the exported ``value`` grid grown by one voxel on every side, the new voxels
    repeating their neighbours on the border, as STEM-cycles.vdb beside it; returns its path.

    Occlux clamps trilinear samples to the border voxels up to the faces of the volume's box
    and has no medium beyond; Cycles interpolates towards the grid's background (0) over the
    voxel past the last centre. With the repeated border, Cycles' samples inside the box are
    Occlux's; the material's box mask removes what lies beyond (see :func:`_material`)."""
    openvdb = bundled_module("openvdb")
    path = Path(vdb_path)
    try:
        grid = openvdb.read(str(path), "value")
    except (KeyError, RuntimeError, ValueError) as e:
        raise HarnessError(f"{path}: no readable `value` grid ({e})") from e
    transform = grid.transform
    if not (
        np.allclose(transform.indexToWorld((0, 0, 0)), spec.origin, rtol=1e-5, atol=1e-6)
        and np.allclose(transform.voxelSize(), spec.spacing, rtol=1e-5)
    ):
        raise HarnessError(
            f"{path}: its grid is not placed as {spec.path} places the volume (voxel (0, 0, 0) "
            f"at {transform.indexToWorld((0, 0, 0))}, not {spec.origin}): export it again"
        )
    dense = np.zeros(spec.dims, dtype=np.float32)  # x, y, z
    grid.copyToArray(dense, ijk=(0, 0, 0))
    padded = openvdb.FloatGrid()
    padded.copyFromArray(np.pad(dense, 1, mode="edge"), ijk=(-1, -1, -1), tolerance=0.0)
    padded.transform = transform
    padded.name = "value"
    padded.gridClass = openvdb.GridClass.FOG_VOLUME
    out = path.with_name(f"{path.stem}-cycles.vdb")
    _write_atomic(out, lambda tmp: openvdb.write(str(tmp), grids=[padded]))
    return out


def _remove_previous(bpy) -> None:
    """Removes the data a previous build made (and nothing else of the session's)."""
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


def _link(tree, socket_out, socket_in) -> None:
    tree.links.new(socket_out, socket_in)


def _socket(sockets, identifier: str):
    """A node socket by identifier (the Mix node's sockets share names across data types)."""
    return next(s for s in sockets if s.identifier == identifier)


def _ramp(tree, stops: Sequence[tuple[float, tuple[float, float, float, float]]]):
    """A Color Ramp node with LINEAR interpolation through (position, RGBA) stops."""
    node = tree.nodes.new("ShaderNodeValToRGB")
    ramp = node.color_ramp
    ramp.interpolation = "LINEAR"
    ramp.color_mode = "RGB"
    while len(ramp.elements) > 1:
        ramp.elements.remove(ramp.elements[-1])
    ramp.elements[0].position = stops[0][0]
    for position, _ in stops[1:]:
        ramp.elements.new(position)
    # Elements are kept sorted by position, as the stops are.
    for element, (_, rgba) in zip(ramp.elements, stops, strict=True):
        element.color = rgba
    return node


def _ramp_positions(points: Sequence[TfPoint]) -> list[float]:
    """Stop positions: the raw values mapped linearly from [first, last] onto [0, 1]."""
    lo, hi = points[0].value, points[-1].value
    if hi <= lo:
        return [0.0] * len(points)
    return [(p.value - lo) / (hi - lo) for p in points]


def _box_mask(tree, box: tuple[Rgb, Rgb]):
    """A shader value that is 1 inside the axis-aligned ``box`` and 0 outside (the volume
    object sits at the origin unrotated, so positions are the grid's world positions)."""
    lo, hi = np.asarray(box[0]), np.asarray(box[1])
    position = tree.nodes.new("ShaderNodeNewGeometry")
    offset = tree.nodes.new("ShaderNodeVectorMath")
    offset.operation = "SUBTRACT"
    offset.inputs[1].default_value = _triple(0.5 * (lo + hi))
    _link(tree, position.outputs["Position"], offset.inputs[0])
    scaled = tree.nodes.new("ShaderNodeVectorMath")
    scaled.operation = "DIVIDE"
    scaled.inputs[1].default_value = _triple(0.5 * (hi - lo))
    _link(tree, offset.outputs["Vector"], scaled.inputs[0])
    # The box is where the largest |coordinate| of the scaled offset is below 1.
    extent = tree.nodes.new("ShaderNodeVectorMath")
    extent.operation = "ABSOLUTE"
    _link(tree, scaled.outputs["Vector"], extent.inputs[0])
    xyz = tree.nodes.new("ShaderNodeSeparateXYZ")
    _link(tree, extent.outputs["Vector"], xyz.inputs[0])
    largest = xyz.outputs["X"]
    for axis in "YZ":
        node = tree.nodes.new("ShaderNodeMath")
        node.operation = "MAXIMUM"
        _link(tree, largest, node.inputs[0])
        _link(tree, xyz.outputs[axis], node.inputs[1])
        largest = node.outputs["Value"]
    inside = tree.nodes.new("ShaderNodeMath")
    inside.operation = "LESS_THAN"
    inside.inputs[1].default_value = 1.0
    _link(tree, largest, inside.inputs[0])
    return inside.outputs["Value"]


def _emission_seen(tree, bounces: int):
    """1 on rays that have scattered at most ``bounces`` times, else 0.

    Occlux's estimators count the emission of the camera segment and of the segments after
    the first ``bounces`` scatterings; a Cycles path that may scatter ``bounces`` more times
    (volume bounces) also collects emission along the ray it casts after its last scattering
    (measured: with 0 bounces, albedo 0.9 and no lights, Cycles adds +26 % to the emission
    image of the phantom; with albedo 0 the two agree)."""
    path = tree.nodes.new("ShaderNodeLightPath")
    seen = tree.nodes.new("ShaderNodeMath")
    seen.operation = "LESS_THAN"
    seen.inputs[1].default_value = bounces + 0.5
    _link(tree, path.outputs["Ray Depth"], seen.inputs[0])
    return seen.outputs["Value"]


def _material(bpy, points: Sequence[TfPoint], box: tuple[Rgb, Rgb], g: float, bounces: int):
    """The transfer function on the ``value`` grid, into a Principled Volume: Density = sigma_t
    inside ``box`` and 0 outside, Color = albedo, Absorption Color black, Anisotropy = g,
    emission per unit length on the rays Occlux counts it on (see :func:`_emission_seen`)."""
    mat = bpy.data.materials.new(f"{PREFIX}-material")
    mat.cycles.volume_interpolation = "LINEAR"  # trilinear, as Occlux samples
    tree = mat.node_tree
    tree.nodes.clear()
    value = tree.nodes.new("ShaderNodeAttribute")
    value.attribute_type = "GEOMETRY"
    value.attribute_name = "value"
    to_unit = tree.nodes.new("ShaderNodeMapRange")
    to_unit.clamp = True  # the transfer function is constant beyond its end points
    to_unit.inputs["From Min"].default_value = points[0].value
    to_unit.inputs["From Max"].default_value = points[-1].value
    _link(tree, value.outputs["Fac"], to_unit.inputs["Value"])
    positions = _ramp_positions(points)
    # Albedo in RGB, sigma_t / max in alpha: one ramp, one table.
    max_sigma = max(p.sigma_t for p in points)
    optics = _ramp(
        tree,
        [(t, (*p.albedo, p.sigma_t / max_sigma)) for t, p in zip(positions, points, strict=True)],
    )
    _link(tree, to_unit.outputs["Result"], optics.inputs["Fac"])
    scale = tree.nodes.new("ShaderNodeMath")
    scale.operation = "MULTIPLY"
    scale.inputs[1].default_value = max_sigma
    _link(tree, optics.outputs["Alpha"], scale.inputs[0])
    density = tree.nodes.new("ShaderNodeMath")
    density.operation = "MULTIPLY"
    _link(tree, scale.outputs["Value"], density.inputs[0])
    _link(tree, _box_mask(tree, box), density.inputs[1])
    volume = tree.nodes.new("ShaderNodeVolumePrincipled")
    _link(tree, density.outputs["Value"], volume.inputs["Density"])
    _link(tree, optics.outputs["Color"], volume.inputs["Color"])
    # A grid named `density` (as `occlux export` writes) would otherwise multiply the density
    # (measured: the engine's transmittance fell from 0.08 to 0.007), and `color` the colour.
    volume.inputs["Density Attribute"].default_value = ""
    volume.inputs["Color Attribute"].default_value = ""
    volume.inputs["Absorption Color"].default_value = (0.0, 0.0, 0.0, 1.0)
    volume.inputs["Anisotropy"].default_value = g
    volume.inputs["Blackbody Intensity"].default_value = 0.0
    max_emission = max(max(p.emission) for p in points)
    if max_emission > 0.0:
        emission = _ramp(
            tree,
            [
                (t, (*(e / max_emission for e in p.emission), 1.0))
                for t, p in zip(positions, points, strict=True)
            ],
        )
        _link(tree, to_unit.outputs["Result"], emission.inputs["Fac"])
        _link(tree, emission.outputs["Color"], volume.inputs["Emission Color"])
        strength = tree.nodes.new("ShaderNodeMath")
        strength.operation = "MULTIPLY"
        strength.inputs[1].default_value = max_emission
        _link(tree, _emission_seen(tree, bounces), strength.inputs[0])
        _link(tree, strength.outputs["Value"], volume.inputs["Emission Strength"])
    else:
        volume.inputs["Emission Strength"].default_value = 0.0
    output = tree.nodes.new("ShaderNodeOutputMaterial")
    output.target = "CYCLES"
    _link(tree, volume.outputs["Volume"], output.inputs["Volume"])
    return mat


def _scaled(rgb: Rgb) -> tuple[tuple[float, float, float, float], float]:
    """An RGB quantity as a colour in [0, 1] and a strength."""
    peak = max(rgb)
    if peak <= 0.0:
        return (0.0, 0.0, 0.0, 1.0), 0.0
    return (*(c / peak for c in rgb), 1.0), peak


def _world(bpy, environment: Rgb, background: Rgb):
    """Radiance ``background`` for camera rays, ``environment`` for every other ray."""
    world = bpy.data.worlds.new(f"{PREFIX}-world")
    tree = world.node_tree
    tree.nodes.clear()
    peak = max(*environment, *background)
    strength = peak if peak > 0.0 else 0.0
    norm = peak if peak > 0.0 else 1.0
    path = tree.nodes.new("ShaderNodeLightPath")
    mix = tree.nodes.new("ShaderNodeMix")
    mix.data_type = "RGBA"
    mix.blend_type = "MIX"
    _socket(mix.inputs, "A_Color").default_value = (*(c / norm for c in environment), 1.0)
    _socket(mix.inputs, "B_Color").default_value = (*(c / norm for c in background), 1.0)
    _link(tree, path.outputs["Is Camera Ray"], _socket(mix.inputs, "Factor_Float"))
    shader = tree.nodes.new("ShaderNodeBackground")
    shader.inputs["Strength"].default_value = strength
    _link(tree, _socket(mix.outputs, "Result_Color"), shader.inputs["Color"])
    output = tree.nodes.new("ShaderNodeOutputWorld")
    _link(tree, shader.outputs["Background"], output.inputs["Surface"])
    return world


def _camera_object(bpy, cam: CameraSpec):
    """Blender's camera looks down its local -Z with local +Y up."""
    from mathutils import Matrix

    data = bpy.data.cameras.new(f"{PREFIX}-camera")
    if cam.perspective:
        data.type = "PERSP"
        if cam.lens_mm is not None:
            data.sensor_fit = "AUTO"  # the sensor spans the larger image side
            data.sensor_width = cam.sensor_mm
            data.lens = cam.lens_mm
        else:
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
        colour, strength = _scaled(light.rgb)
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


def _cycles_settings(scene, bounces: int) -> None:
    """Unbiased, unfiltered, undenoised path tracing on the CPU."""
    render = scene.render
    render.engine = "CYCLES"
    render.film_transparent = False
    render.use_persistent_data = True  # renders at other seeds reuse the volume's octree
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
    scene_path: str | os.PathLike[str],
    vdb_path: str | os.PathLike[str],
    estimator: str,
    bounces: int = 0,
    g: float = 0.0,
):
    """Builds the Occlux scene as a new Blender scene set up to render ``estimator`` with Cycles
    and returns it (a ``bpy.types.Scene``; render it with :func:`render_scene`). The volume is
    the ``value`` grid of ``vdb_path`` (from ``occlux export``). ``bounces`` is Cycles' volume
    bounces for "multiple" (0 for the others); ``g`` the Henyey-Greenstein asymmetry for
    "single" and "multiple" ("ambient" is isotropic). Data made by a previous build is removed."""
    if estimator not in ESTIMATORS:
        raise HarnessError(f"estimator '{estimator}': Cycles can reproduce {', '.join(ESTIMATORS)}")
    if not -1.0 < g < 1.0:
        raise HarnessError(f"g must be in (-1, 1), got {g}")
    if estimator != "multiple":
        bounces = 0
    if estimator == "ambient":
        g = 0.0
    spec = load_scene(scene_path)
    bpy = _bpy()
    _remove_previous(bpy)
    scene = bpy.data.scenes.new(f"{PREFIX}-scene")
    grid_path = padded_value_grid(vdb_path, spec)
    volume = bpy.data.volumes.new(f"{PREFIX}-volume")
    volume.filepath = str(grid_path.resolve())
    if not volume.grids.load():
        raise HarnessError(f"{grid_path}: Blender cannot read it: {volume.grids.error_message}")
    volume.render.precision = "FULL"
    volume.render.space = "OBJECT"
    volume.render.clipping = 0.0
    volume.materials.append(_material(bpy, spec.points, spec.box, g, bounces))
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
    scene.world = _world(bpy, environment, spec.background)
    for light in _light_objects(bpy, lights):
        scene.collection.objects.link(light)
    _cycles_settings(scene, bounces)
    return scene


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
    ``occlux/camera`` header of its EXR)."""
    ours = camera_frustum(scene)
    theirs = {
        "position": occlux_camera["position"],
        "forward": occlux_camera["forward"],
        "up": occlux_camera["up"],
        "half_extent": occlux_camera["half_extent"],
    }
    if ours["perspective"] != occlux_camera["projection"].startswith("Perspective"):
        raise HarnessError(f"projection differs: Blender {ours}, Occlux {occlux_camera}")
    for key, want in theirs.items():
        got = np.asarray(ours[key])
        if not np.allclose(got, want, rtol=tolerance, atol=tolerance):
            raise HarnessError(f"camera {key} differs: Blender {got.tolist()}, Occlux {want}")


# ---- Rendering ----


@dataclass
class CyclesImage:
    """Per-pixel mean and standard error of K Cycles renders, (height, width, 3) float64, row 0
    at the top; the seeds used and the wall time of all renders."""

    mean: np.ndarray
    stderr: np.ndarray
    seeds: list[int]
    spp_per_seed: int
    seconds: float


def bpy_site_packages() -> Path:
    """The folder of the Python packages Blender bundles (OpenImageIO, OpenVDB, USD), which the
    bpy wheel does not put on sys.path."""
    for root in site.getsitepackages():
        path = Path(root) / "bpy" / "5.0" / "python" / "lib" / "python3.11" / "site-packages"
        if path.is_dir():
            return path
    raise HarnessError("the bpy 5.0 wheel is not installed in this Python")


def bundled_module(name: str):
    """A module that Blender bundles (``OpenImageIO``, ``openvdb``): importable inside Blender,
    from the bpy wheel's own site-packages otherwise."""
    try:
        return importlib.import_module(name)
    except ImportError:
        sys.path.append(str(bpy_site_packages()))
        return importlib.import_module(name)


def read_channels(path: str | os.PathLike[str]) -> tuple[dict[str, np.ndarray], dict[str, str]]:
    """Every channel of an image file (float32, row 0 at the top) and its string attributes."""
    oiio = bundled_module("OpenImageIO")
    image = oiio.ImageInput.open(str(path))
    if not image:
        raise HarnessError(f"{path}: cannot read it: {oiio.geterror()}")
    try:
        spec = image.spec()
        pixels = image.read_image(format="float")
        attributes = {a.name: a.value for a in spec.extra_attribs if isinstance(a.value, str)}
        names = list(spec.channelnames)
    finally:
        image.close()
    if pixels is None:
        raise HarnessError(f"{path}: cannot read its pixels: {oiio.geterror()}")
    return {name: pixels[..., c] for c, name in enumerate(names)}, attributes


@contextlib.contextmanager
def _quiet_stdout():
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


def render_scene(
    scene,
    spp: int,
    seeds: int = DEFAULT_SEEDS,
    progress: Callable[[int, int], object] | None = None,
) -> CyclesImage:
    """Renders a built scene ``seeds`` times with distinct seeds (none equal to Occlux's), each
    with ``spp // seeds`` samples, and returns the per-pixel mean and standard error.

    Each render is a subset (its own samples) of one SEQUENCE_LENGTH-sample sequence: Cycles
    renders whose sample count is small are biased (see SEQUENCE_LENGTH)."""
    if seeds < 2:
        raise HarnessError(f"seeds must be at least 2 (for a standard error), got {seeds}")
    per_seed = spp // seeds
    if per_seed < 1:
        raise HarnessError(f"spp ({spp}) must be at least the number of seeds ({seeds})")
    bpy = _bpy()
    c = scene.cycles
    c.samples = max(SEQUENCE_LENGTH, per_seed * seeds)
    c.use_sample_subset = True
    c.sample_subset_length = per_seed
    seed_list = [CYCLES_FIRST_SEED + k for k in range(seeds)]
    assert OCCLUX_SEED not in seed_list
    total = total_sq = 0.0
    started = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="occlux-cycles-") as tmp:
        for k, seed in enumerate(seed_list):
            c.seed = seed
            c.sample_offset = k * per_seed
            scene.render.filepath = str(Path(tmp) / f"seed{seed}.exr")
            with _quiet_stdout():
                result = bpy.ops.render.render(write_still=True, scene=scene.name)
            if result != {"FINISHED"}:
                raise HarnessError(f"Cycles render at seed {seed} ended with {result}")
            channels, _ = read_channels(scene.render.filepath)
            rgb = np.stack([channels[ch] for ch in "RGB"], axis=-1).astype(np.float64)
            total = total + rgb
            total_sq = total_sq + rgb * rgb
            if progress is not None:
                progress(k + 1, seeds)
    seconds = time.perf_counter() - started
    mean = total / seeds
    variance = np.maximum(total_sq - seeds * mean * mean, 0.0) / (seeds - 1)
    return CyclesImage(mean, np.sqrt(variance / seeds), seed_list, per_seed, seconds)


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


# ---- Comparison ----


@dataclass
class OccluxImage:
    """An ``occlux reference`` image: mean RGBA and standard error RGB, (height, width, c), and
    its header's ``occlux/reference`` and ``occlux/camera`` descriptions."""

    beauty: np.ndarray
    stderr: np.ndarray
    reference: dict[str, Any]
    camera: dict[str, Any]


def read_reference(path: str | os.PathLike[str]) -> OccluxImage:
    """Reads the EXR that ``occlux reference`` writes (layers ``beauty`` and ``stderr``)."""
    channels, attributes = read_channels(path)
    try:
        beauty = np.stack([channels[f"beauty.{c}"] for c in "RGBA"], axis=-1)
        stderr = np.stack([channels[f"stderr.{c}"] for c in "RGB"], axis=-1)
        reference = json.loads(attributes["occlux/reference"])
        camera = json.loads(attributes["occlux/camera"])
    except KeyError as e:
        raise HarnessError(f"{path}: not an `occlux reference` image (no {e})") from e
    return OccluxImage(beauty.astype(np.float64), stderr.astype(np.float64), reference, camera)


@dataclass
class Report:
    """How an Occlux image and a Cycles image differ over the mask (Occlux alpha > mask_alpha).

    z = (occlux - cycles) / sqrt(se_occlux^2 + se_cycles^2 + noise_floor^2) per pixel and
    channel; ``rmse`` is the radiance RMSE and ``rms_noise`` the RMS of the combined standard
    error (without the floor), over the mask."""

    pixels: int
    mask_alpha: float
    noise_floor: float
    mean_z: float
    rms_z: float
    fraction_over_3: float
    max_abs_z: float
    rmse: float
    rms_noise: float
    rmse_over_noise: float
    mean_occlux: float
    mean_cycles: float

    def agrees(self) -> bool:
        """Whether the images agree within noise: RMS z in RMS_Z_RANGE, |mean z| at most
        MAX_ABS_MEAN_Z, and at most MAX_FRACTION_OVER_3 of the z scores beyond 3."""
        return (
            RMS_Z_RANGE[0] <= self.rms_z <= RMS_Z_RANGE[1]
            and abs(self.mean_z) <= MAX_ABS_MEAN_Z
            and self.fraction_over_3 <= MAX_FRACTION_OVER_3
        )

    def table(self) -> str:
        rows = [
            ("pixels compared", f"{self.pixels} (Occlux alpha > {self.mask_alpha})"),
            ("noise floor", f"{self.noise_floor:.3g}"),
            ("mean radiance", f"Occlux {self.mean_occlux:.5g}, Cycles {self.mean_cycles:.5g}"),
            ("mean z", f"{self.mean_z:+.3f}"),
            ("RMS z", f"{self.rms_z:.3f}"),
            ("|z| > 3", f"{100 * self.fraction_over_3:.2f} %"),
            ("max |z|", f"{self.max_abs_z:.2f}"),
            ("RMSE", f"{self.rmse:.4g} ({self.rmse_over_noise:.3f} x the RMS noise)"),
            ("verdict", "agree within noise" if self.agrees() else "DISAGREE"),
        ]
        return "\n".join(f"{k:<16} {v}" for k, v in rows)


def z_scores(
    occlux: OccluxImage,
    cycles_mean: np.ndarray,
    cycles_stderr: np.ndarray,
    floor: float = 0.0,
) -> np.ndarray:
    """Per-pixel, per-channel z = (occlux - cycles) / sqrt(se_o^2 + se_c^2 + floor^2); 0 where
    the denominator and the difference are both zero, NaN where only the denominator is."""
    diff = occlux.beauty[..., :3] - cycles_mean
    sigma = np.sqrt(occlux.stderr**2 + cycles_stderr**2 + floor**2)
    with np.errstate(divide="ignore", invalid="ignore"):
        z = diff / sigma
    z[(sigma == 0.0) & (diff == 0.0)] = 0.0
    z[(sigma == 0.0) & (diff != 0.0)] = np.nan
    return z


def _mask(occlux: OccluxImage, mask_alpha: float) -> np.ndarray:
    mask = occlux.beauty[..., 3] > mask_alpha
    if not mask.any():
        raise HarnessError(f"no pixel has Occlux alpha > {mask_alpha}: the volume is not in view")
    return mask


def noise_floor(occlux: OccluxImage, mask_alpha: float = MASK_ALPHA) -> float:
    """The floor under the standard errors of z (see NOISE_FLOOR)."""
    mean = float(occlux.beauty[..., :3][_mask(occlux, mask_alpha)].mean())
    return NOISE_FLOOR * mean / math.sqrt(occlux.reference["spp"])


def compare(
    occlux: OccluxImage,
    cycles_mean: np.ndarray,
    cycles_stderr: np.ndarray,
    mask_alpha: float = MASK_ALPHA,
) -> Report:
    """Compares an Occlux reference with a Cycles estimate of the same image over the pixels
    the volume covers (Occlux alpha > ``mask_alpha``)."""
    if cycles_mean.shape != (*occlux.beauty.shape[:2], 3):
        raise HarnessError(
            f"image sizes differ: Occlux {occlux.beauty.shape[:2]}, Cycles {cycles_mean.shape[:2]}"
        )
    mask = _mask(occlux, mask_alpha)
    floor = noise_floor(occlux, mask_alpha)
    z = z_scores(occlux, cycles_mean, cycles_stderr, floor)[mask]
    if np.isnan(z).any():
        bad = int(np.isnan(z).any(axis=-1).sum())
        raise HarnessError(f"{bad} pixels differ although both have zero standard error")
    diff = (occlux.beauty[..., :3] - cycles_mean)[mask]
    noise = (occlux.stderr**2 + cycles_stderr**2)[mask]
    rmse = float(np.sqrt(np.mean(diff**2)))
    rms_noise = float(np.sqrt(np.mean(noise)))
    return Report(
        pixels=int(mask.sum()),
        mask_alpha=mask_alpha,
        noise_floor=floor,
        mean_z=float(z.mean()),
        rms_z=float(np.sqrt(np.mean(z**2))),
        fraction_over_3=float(np.mean(np.abs(z) > 3.0)),
        max_abs_z=float(np.abs(z).max()),
        rmse=rmse,
        rms_noise=rms_noise,
        rmse_over_noise=rmse / rms_noise if rms_noise > 0.0 else math.inf,
        mean_occlux=float(occlux.beauty[..., :3][mask].mean()),
        mean_cycles=float(cycles_mean[mask].mean()),
    )


def error_map(occlux: OccluxImage, z: np.ndarray, mask_alpha: float = MASK_ALPHA) -> np.ndarray:
    """An 8-bit RGB picture of the mean z over the channels, clipped to [-Z_CLIP, Z_CLIP]: blue
    where Occlux is darker than Cycles, red where brighter, white where they agree; pixels
    outside the mask are grey."""
    t = np.clip(np.nan_to_num(z.mean(axis=-1)) / Z_CLIP, -1.0, 1.0)[..., None]
    white = np.array([1.0, 1.0, 1.0])
    blue = np.array([0.23, 0.30, 0.75])
    red = np.array([0.71, 0.02, 0.15])
    rgb = np.where(t < 0.0, white + (blue - white) * -t, white + (red - white) * t)
    rgb[occlux.beauty[..., 3] <= mask_alpha] = 0.5
    return np.round(rgb * 255.0).astype(np.uint8)


def _write_atomic(path: Path, write: Callable[[Path], None]) -> None:
    """Writes through a temporary file in the same folder, then renames it into place."""
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.stem}-", suffix=path.suffix, dir=path.parent)
    os.close(fd)
    try:
        write(Path(tmp))
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def _write_image(path: Path, pixels: np.ndarray, names: Sequence[str]) -> None:
    """An image through OpenImageIO: uint8 pixels as they are, floats as float32."""
    oiio = bundled_module("OpenImageIO")
    height, width, channels = pixels.shape
    fmt = "uint8" if pixels.dtype == np.uint8 else "float"
    spec = oiio.ImageSpec(width, height, channels, fmt)
    spec.channelnames = tuple(names)

    def write(tmp: Path) -> None:
        out = oiio.ImageOutput.create(str(tmp))
        if not out or not out.open(str(tmp), spec):
            raise HarnessError(f"{path}: cannot write it: {oiio.geterror()}")
        ok = out.write_image(pixels if fmt == "uint8" else pixels.astype(np.float32))
        out.close()
        if not ok:
            raise HarnessError(f"{path}: cannot write it: {oiio.geterror()}")

    _write_atomic(path, write)


def write_outputs(
    out: Path, stem: str, occlux: OccluxImage, cycles: CyclesImage, report: Report, extra: dict
) -> list[Path]:
    """OUT/STEM-cycles.exr (Cycles' mean and standard error), OUT/STEM-zmap.png (the error
    map) and OUT/STEM-report.json (the report and ``extra``)."""
    exr = out / f"{stem}-cycles.exr"
    names = [f"beauty.{c}" for c in "RGB"] + [f"stderr.{c}" for c in "RGB"]
    _write_image(exr, np.concatenate([cycles.mean, cycles.stderr], axis=-1), names)
    png = out / f"{stem}-zmap.png"
    z = z_scores(occlux, cycles.mean, cycles.stderr, report.noise_floor)
    _write_image(png, error_map(occlux, z, report.mask_alpha), "RGB")
    summary = {
        **extra,
        **asdict(report),
        "agrees": report.agrees(),
        "criteria": {
            "rms_z": list(RMS_Z_RANGE),
            "max_abs_mean_z": MAX_ABS_MEAN_Z,
            "max_fraction_over_3": MAX_FRACTION_OVER_3,
        },
        "cycles_seeds": cycles.seeds,
        "cycles_spp_per_seed": cycles.spp_per_seed,
    }
    js = out / f"{stem}-report.json"
    _write_atomic(js, lambda tmp: tmp.write_text(json.dumps(summary, indent=2) + "\n"))
    return [exr, png, js]


# ---- The whole check, and the command line ----


def occlux_binary() -> Path:
    """The Occlux CLI: $OCCLUX_BIN, else `occlux` on PATH, else target/release/occlux of the
    checkout this package sits in."""
    if "OCCLUX_BIN" in os.environ:
        return Path(os.environ["OCCLUX_BIN"])
    found = shutil.which("occlux")
    if found:
        return Path(found)
    checkout = Path(__file__).resolve().parents[3] / "target" / "release" / "occlux"
    if checkout.is_file():
        return checkout
    raise HarnessError("the occlux CLI was not found: set OCCLUX_BIN or put it on PATH")


def run_occlux(*args: str) -> float:
    """Runs the Occlux CLI; returns its wall time. A failure raises with its error message."""
    started = time.perf_counter()
    result = subprocess.run(
        [str(occlux_binary()), "--quiet", *args], capture_output=True, text=True
    )
    if result.returncode != 0:
        raise HarnessError(f"occlux {' '.join(args)} failed: {result.stderr.strip()}")
    return time.perf_counter() - started


@dataclass
class Check:
    report: Report
    occlux_seconds: float
    cycles: CyclesImage
    files: list[Path]


def check(
    scene_path: str | os.PathLike[str],
    estimator: str,
    spp: int,
    out: str | os.PathLike[str],
    seeds: int = DEFAULT_SEEDS,
    bounces: int = 8,
    g: float = 0.0,
) -> Check:
    """The whole cross-check: `occlux export` (the VDB), `occlux reference`, Cycles, and the
    comparison, written into ``out``."""
    scene_path, out = Path(scene_path), Path(out)
    if estimator not in ESTIMATORS:
        raise HarnessError(f"estimator '{estimator}': Cycles can reproduce {', '.join(ESTIMATORS)}")
    if estimator != "multiple":
        bounces = 0
    if estimator == "ambient":
        g = 0.0
    run_occlux("export", str(scene_path), "-o", str(out))
    stem = scene_path.stem
    occlux_seconds = run_occlux(
        "reference", str(scene_path), "--estimator", estimator, "--spp", str(spp),
        "--seed", str(OCCLUX_SEED), "--bounces", str(bounces), "--g", str(g), "-o", str(out),
    )  # fmt: skip
    occlux = read_reference(out / f"{stem}-{estimator}.exr")
    scene = build_scene(scene_path, out / f"{stem}.vdb", estimator, bounces, g)
    check_camera(scene, occlux.camera)
    cycles = render_scene(scene, spp, seeds)
    report = compare(occlux, cycles.mean, cycles.stderr)
    extra = {
        "scene": str(scene_path),
        "estimator": estimator,
        "spp": spp,
        "bounces": bounces,
        "g": g,
        "occlux_seconds": occlux_seconds,
        "cycles_seconds": cycles.seconds,
    }
    files = write_outputs(out, f"{stem}-{estimator}", occlux, cycles, report, extra)
    return Check(report, occlux_seconds, cycles, files)


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog="python -m occlux.cycles",
        description="Render an Occlux scene with Cycles and compare it with Occlux's Monte Carlo "
        "reference, pixel by pixel in units of the combined standard error.",
    )
    parser.add_argument("scene", type=Path, help="the scene file (TOML)")
    parser.add_argument("--estimator", choices=ESTIMATORS, default="single")
    parser.add_argument("--spp", type=int, default=256, help="samples per pixel, for both")
    parser.add_argument(
        "--seeds", type=int, default=DEFAULT_SEEDS, help="Cycles renders (spp / seeds samples each)"
    )
    parser.add_argument("--bounces", type=int, default=8, help="volume bounces (multiple only)")
    parser.add_argument("--g", type=float, default=0.0, help="Henyey-Greenstein asymmetry")
    parser.add_argument("--out", type=Path, default=Path("occlux-check"))
    args = parser.parse_args(argv)
    try:
        result = check(
            args.scene, args.estimator, args.spp, args.out, args.seeds, args.bounces, args.g
        )
    except OccluxError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    print(f"{args.scene} {args.estimator}, {args.spp} spp")
    print(f"{'Occlux time':<16} {result.occlux_seconds:.2f} s")
    print(f"{'Cycles time':<16} {result.cycles.seconds:.2f} s ({len(result.cycles.seeds)} seeds)")
    print(result.report.table())
    for path in result.files:
        print(f"wrote {path}")
    return 0 if result.report.agrees() else EXIT_DISAGREE


if __name__ == "__main__":
    sys.exit(main())
