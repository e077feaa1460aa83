"""The scene as the Cycles mapping needs it, from the core: :meth:`occlux.Scene.describe` (camera,
lights, background), :meth:`occlux.Classification.raw_points` (the transfer function on the
volume's raw values) and the placed volume (:meth:`occlux.Scene.load_volume`). Nothing here
re-reads the scene file or re-derives a default: what Cycles is given is what Occlux renders."""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from occlux._occlux import Scene, Volume

from .common import HarnessError, Rgb

MAX_RAMP_STOPS = 32
"""Blender's Color Ramp holds at most 32 stops: transfer functions with more points are refused."""


@dataclass(frozen=True)
class TfPoint:
    """A transfer-function control point in the volume's raw values, density scale applied."""

    value: float
    sigma_t: float
    albedo: Rgb
    emission: Rgb


@dataclass(frozen=True)
class CameraSpec:
    """The scene's camera as the core resolved it (src/camera.rs): an orthonormal frame and a
    projection, ``fov_y`` (radians, vertical) for perspective cameras or ``ortho_scale`` (the
    extent along the larger image side) for orthographic ones. A scene's ``lens_mm`` and
    ``sensor_mm`` arrive as the vertical field of view they make with Blender's sensor fit
    AUTO."""

    position: Rgb
    forward: Rgb
    up: Rgb
    right: Rgb
    perspective: bool
    fov_y: float | None
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
    cells, where Occlux's medium ends). ``path`` is the scene file, None for a scene built in
    memory."""

    path: Path | None
    dims: tuple[int, int, int]
    origin: Rgb
    spacing: Rgb
    box: tuple[Rgb, Rgb]
    points: tuple[TfPoint, ...]
    camera: CameraSpec
    ambient: Rgb
    background: Rgb
    lights: tuple[LightSpec, ...]

    @property
    def label(self) -> str:
        """How messages name the scene."""
        return str(self.path) if self.path is not None else "the scene"


def _triple(values: Any) -> Rgb:
    return (float(values[0]), float(values[1]), float(values[2]))


def camera_spec(camera: dict[str, Any]) -> CameraSpec:
    """The ``camera`` of :meth:`occlux.Scene.describe`."""
    projection = camera["projection"]
    perspective = projection["type"] == "perspective"
    return CameraSpec(
        position=_triple(camera["position"]),
        forward=_triple(camera["forward"]),
        up=_triple(camera["up"]),
        right=_triple(camera["right"]),
        perspective=perspective,
        fov_y=float(projection["fov_y"]) if perspective else None,
        ortho_scale=None if perspective else float(projection["scale"]),
        width=int(camera["width"]),
        height=int(camera["height"]),
    )


def lights_spec(lighting: dict[str, Any], label: str) -> tuple[Rgb, tuple[LightSpec, ...]]:
    """The ambient radiance (the sum of the ambient lights) and the other lights of the
    ``lighting`` of :meth:`occlux.Scene.describe`."""
    ambient = [0.0, 0.0, 0.0]
    lights = []
    for i, light in enumerate(lighting["lights"]):
        kind = light["type"]
        if kind == "ambient":
            ambient = [a + float(r) for a, r in zip(ambient, light["radiance"], strict=True)]
        elif kind == "directional":
            lights.append(LightSpec(kind, _triple(light["to_light"]), _triple(light["irradiance"])))
        elif kind == "point":
            lights.append(LightSpec(kind, _triple(light["position"]), _triple(light["intensity"])))
        else:
            raise HarnessError(f"{label}: lights[{i}] of type '{kind}' has no Cycles counterpart")
    return _triple(ambient), tuple(lights)


def tf_points(scene: Scene, volume: Volume, label: str) -> tuple[TfPoint, ...]:
    """The core's control points in raw values (sorted, density scale applied), refused where
    Blender's Color Ramp cannot hold them."""
    raw = scene.classification.raw_points(volume)
    if raw is None:
        raise HarnessError(
            f"{label}: the classification is a 2D transfer function (value x gradient "
            "magnitude); the Cycles mapping needs a 1D one"
        )
    points = tuple(
        TfPoint(float(value), float(sigma_t), _triple(albedo), _triple(emission))
        for value, sigma_t, albedo, emission in raw
    )
    if len(points) > MAX_RAMP_STOPS:
        raise HarnessError(
            f"{label}: the transfer function has {len(points)} control points; Blender's Color "
            f"Ramp holds at most {MAX_RAMP_STOPS}"
        )
    if max(p.sigma_t for p in points) <= 0.0:
        raise HarnessError(f"{label}: the transfer function has sigma_t = 0 everywhere")
    return points


def core_scene(scene: str | os.PathLike[str] | Scene) -> tuple[Scene, Path | None]:
    """An ``occlux.Scene`` and its file: a scene file is loaded (and validated) by the core, a
    Scene object is taken as it is."""
    if isinstance(scene, Scene):
        return scene, None
    path = Path(scene)
    return Scene.load(path), path


def load_scene(scene: str | os.PathLike[str] | Scene, volume: Volume | None = None) -> SceneSpec:
    """What Cycles needs of a scene: a scene file (validated by the core) or an
    ``occlux.Scene`` (e.g. from :meth:`occlux.Scene.from_dict`), settled as ``occlux render``
    settles it (:meth:`occlux.Scene.settle`: the content centred, the camera framed on it), so
    that Cycles sees the volume where Occlux renders it. ``volume`` is the scene's volume if the
    caller has settled the same ``occlux.Scene`` already (then pass that object, not a path)."""
    core, path = core_scene(scene)
    label = str(path) if path is not None else "the scene"
    if volume is None:
        volume, _ = core.settle()
    described = core.describe()
    ambient, lights = lights_spec(described["lighting"], label)
    return SceneSpec(
        path=path,
        dims=volume.dims,
        origin=volume.origin,
        spacing=volume.spacing,
        box=volume.bounds,
        points=tf_points(core, volume, label),
        camera=camera_spec(described["camera"]),
        ambient=ambient,
        background=_triple(described["lighting"]["background"]),
        lights=lights,
    )
