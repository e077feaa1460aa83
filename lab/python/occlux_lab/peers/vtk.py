"""VTK's GPU volume ray caster (``vtkOpenGLGPUVolumeRayCastMapper``) as a peer of ``occlux
chart``: the renderer a scientist reaches for first, mapped onto Occlux's optical model so that
its images are comparable pixel for pixel with the path-traced truth.

``python -m occlux_lab.peers.vtk SCENE --estimator {ambient,single,multiple} --out DIR`` renders the
scene at a few sample distances (and, lit by suns or lamps, once without shadows), one EXR each,
and writes ``DIR/vtk-ESTIMATOR-curve.json`` (:func:`render_curve`). docs/peers-vtk.md has the
mapping, its limits and what it measures on the engine.

The mapping (each point checked by tests/python/test_peers_vtk.py):

- Volume: Occlux's voxel centres sit at ``origin + (i, j, k) * spacing`` and its medium fills the
  box of their cells, trilinear samples clamped to the border voxels inside it. VTK's *cell*
  data has exactly that: an image of (nx + 1, ny + 1, nz + 1) points from ``origin - spacing /
  2`` whose cells hold the values; the 3D texture's texel centres are the cell centres and the
  texture clamps at its edge. The image is padded with void cells (extinction 0) to a cube, since
  VTK marches its shadow rays in texture space with the view step's texture length: only in a
  cube is that one world length in every direction (see :func:`cube_padding`).
- Transfer function: opacity ``1 - exp(-sigma_t(v) d)`` with ``SetScalarOpacityUnitDistance(d)``
  at each setting's sample distance d (so VTK's opacity correction is the identity and nothing
  saturates in single precision), colour = albedo, both sampled densely on Occlux's
  piecewise-linear function of the raw value; linear interpolation.
- Ambient light (``ambient``): VTK has no environment light for volumes, so no ambient occlusion:
  shading off, colour = albedo, the image scaled by the ambient radiance. That is Occlux's
  ``unshaded`` method under ambient light, an upper bound of the truth.
- Suns and lamps (``single``, ``multiple``): VTK's volumetric scattering
  (``SetVolumetricScatteringBlending(1)``: at exactly 1 the blend weight is 1 whatever the
  gradient, i.e. no surface shading; at 2 VTK's formula weighs strong gradients by up to 3),
  whose Henyey-Greenstein phase lacks the 1 / (4 pi) of a normalised one: a sun of irradiance E
  is a light of intensity E / (4 pi), a lamp of intensity I one of intensity I / (4 pi) with
  attenuation 1 / r^2. Ambient, specular coefficients 0, diffuse 1. Shadows:
  ``SetGlobalIlluminationReach(1)`` (one texture unit: the padded cube's side), off with 0.
  There is no multiple scattering: ``multiple`` is rendered as single scattering.
- Camera: the core's resolved frame and vertical field of view (or orthographic half height);
  rays go through pixel centres as Occlux's do.
- Output: VTK's window framebuffer is 8-bit; it is replaced by a float32 one (see
  :class:`VtkRenderer`), the background is cleared to 0 and Occlux's background composited
  afterwards with VTK's alpha, so radiance above 1 survives and nothing is quantised.
"""

from __future__ import annotations

import math
import os
import statistics
import sys
import time
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt
from occlux._occlux import OccluxError, Scene, write_exr_layers

from .common import ESTIMATORS, CurvePoint, parser, write_curve

PEER = "vtk"

Rgb = tuple[float, float, float]

TF_SAMPLES = 1024
"""Points of VTK's transfer functions over the data's value range (plus Occlux's own control
points): VTK interpolates opacity linearly between them where Occlux interpolates sigma_t, so they
are dense enough that the two agree within a fraction of a percent."""

REPEATS = 3
"""Renders per setting; the curve reports their median."""

TIMING = (
    "median of 3 renders after one warm-up render (shader compilation excluded), each from the "
    "loaded Occlux volume: the padded vtkImageData, transfer functions, a fresh "
    "vtkVolume/mapper (so the 3D texture upload), the render and the float read-back"
)


class VtkPeerError(OccluxError):
    """A scene that VTK's ray caster cannot render as Occlux's optical model does; the message
    names the scene and the problem."""


def vtk_modules() -> dict[str, Any]:
    """VTK's classes that the peer uses, imported with offscreen EGL rendering (Mesa's software
    OpenGL on a machine without a display) unless the environment chose another window."""
    os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")
    try:
        import vtkmodules.vtkRenderingOpenGL2
        import vtkmodules.vtkRenderingVolumeOpenGL2  # noqa: F401
        from vtkmodules.util.numpy_support import numpy_to_vtk, vtk_to_numpy
        from vtkmodules.vtkCommonCore import VTK_FLOAT, vtkFloatArray, vtkVersion
        from vtkmodules.vtkCommonDataModel import vtkImageData, vtkPiecewiseFunction
        from vtkmodules.vtkRenderingCore import (
            vtkColorTransferFunction,
            vtkLight,
            vtkRenderer,
            vtkRenderWindow,
            vtkVolume,
            vtkVolumeProperty,
        )
        from vtkmodules.vtkRenderingVolumeOpenGL2 import vtkOpenGLGPUVolumeRayCastMapper
    except ImportError as e:
        raise VtkPeerError(f"the VTK peer needs VTK 9.x: pip install vtk==9.7.2 ({e})") from e
    return {
        "VTK_FLOAT": VTK_FLOAT,
        "vtkFloatArray": vtkFloatArray,
        "version": vtkVersion.GetVTKVersion(),
        "vtkImageData": vtkImageData,
        "vtkPiecewiseFunction": vtkPiecewiseFunction,
        "vtkColorTransferFunction": vtkColorTransferFunction,
        "vtkLight": vtkLight,
        "vtkRenderer": vtkRenderer,
        "vtkRenderWindow": vtkRenderWindow,
        "vtkVolume": vtkVolume,
        "vtkVolumeProperty": vtkVolumeProperty,
        "Mapper": vtkOpenGLGPUVolumeRayCastMapper,
        "numpy_to_vtk": numpy_to_vtk,
        "vtk_to_numpy": vtk_to_numpy,
    }


# ---------------------------------------------------------------------------------------------
# The scene, as the core resolved it


@dataclass(frozen=True)
class Light:
    """A sun (``vector``: unit direction towards it, ``rgb``: irradiance) or a lamp
    (``vector``: position, ``rgb``: radiant intensity, irradiance rgb / r^2)."""

    kind: str
    vector: Rgb
    rgb: Rgb


@dataclass(frozen=True)
class Camera:
    """The core's camera (src/camera.rs): orthonormal frame, ``fov_y`` (radians, vertical) for a
    perspective camera or ``half_height`` (world units) for an orthographic one."""

    position: Rgb
    forward: Rgb
    up: Rgb
    perspective: bool
    fov_y: float
    half_height: float
    width: int
    height: int


@dataclass(frozen=True)
class VtkScene:
    """What the peer takes from an Occlux scene: the placed volume's values and grid, the
    transfer function on raw values (sorted control points, density scale applied), the camera,
    the lighting of the estimator and the background."""

    label: str
    values: npt.NDArray[np.float32]
    origin: Rgb
    spacing: Rgb
    points: tuple[tuple[float, float, Rgb], ...]
    camera: Camera
    ambient: Rgb
    lights: tuple[Light, ...]
    background: Rgb

    @property
    def value_range(self) -> tuple[float, float]:
        return float(self.values.min()), float(self.values.max())


def _triple(values: Any) -> Rgb:
    return (float(values[0]), float(values[1]), float(values[2]))


def load_scene(scene: str | os.PathLike[str] | Scene, estimator: str) -> VtkScene:
    """The scene file (or Scene) as VTK will render it under ``estimator``'s lighting: ambient
    lights for ``ambient``, suns and lamps for ``single`` and ``multiple`` (the chart's scene
    files hold only those). Raises :class:`VtkPeerError` for what VTK cannot render: a 2D
    transfer function, emission, a lighting without its lights."""
    if estimator not in ESTIMATORS:
        raise VtkPeerError(f"estimator '{estimator}': expected one of {', '.join(ESTIMATORS)}")
    if isinstance(scene, Scene):
        core, label = scene, "the scene"
    else:
        core, label = Scene.load(Path(scene)), str(scene)
    volume, _ = core.settle()  # as `occlux render`: the content centred, the camera framed
    described = core.describe()
    raw = core.classification.raw_points(volume)
    if raw is None:
        raise VtkPeerError(
            f"{label}: the classification is a 2D transfer function (value x gradient "
            "magnitude); VTK's scalar opacity needs a 1D one"
        )
    if any(max(emission) > 0.0 for _, _, _, emission in raw):
        raise VtkPeerError(
            f"{label}: the transfer function emits light; VTK's ray caster has no emission "
            "term beside its lights"
        )
    points = tuple((float(v), float(s), _triple(a)) for v, s, a, _ in raw)
    if max(s for _, s, _ in points) <= 0.0:
        raise VtkPeerError(f"{label}: the transfer function has sigma_t = 0 everywhere")

    cam = described["camera"]
    projection = cam["projection"]
    perspective = projection["type"] == "perspective"
    camera = Camera(
        position=_triple(cam["position"]),
        forward=_triple(cam["forward"]),
        up=_triple(cam["up"]),
        perspective=perspective,
        fov_y=float(projection["fov_y"]) if perspective else 0.0,
        half_height=float(cam["half_extent"][1]),
        width=int(cam["width"]),
        height=int(cam["height"]),
    )

    ambient = np.zeros(3)
    lights: list[Light] = []
    for light in described["lighting"]["lights"]:
        kind = light["type"]
        if kind == "ambient":
            ambient += np.asarray(light["radiance"], dtype=float)
        elif kind == "directional":
            lights.append(Light(kind, _triple(light["to_light"]), _triple(light["irradiance"])))
        elif kind == "point":
            lights.append(Light(kind, _triple(light["position"]), _triple(light["intensity"])))
        else:
            raise VtkPeerError(f"{label}: a light of type '{kind}' has no VTK counterpart")
    if estimator == "ambient":
        lights = []
        if ambient.max() <= 0.0:
            raise VtkPeerError(f"{label}: the ambient lighting needs an ambient light")
    else:
        ambient[:] = 0.0
        if not lights:
            raise VtkPeerError(f"{label}: the {estimator} lighting needs a sun or a lamp")

    return VtkScene(
        label=label,
        values=np.ascontiguousarray(volume.values, dtype=np.float32),
        origin=_triple(volume.origin),
        spacing=_triple(volume.spacing),
        points=points,
        camera=camera,
        ambient=_triple(ambient),
        lights=tuple(lights),
        background=_triple(described["lighting"]["background"]),
    )


# ---------------------------------------------------------------------------------------------
# The volume and its transfer function


def cube_padding(dims: Sequence[int], spacing: Sequence[float]) -> tuple[int, int, int]:
    """Void cells to add after the last along x, y, z so that the box's sides are equal (to
    within one voxel).

    VTK's shadow ray (``volumeShadow`` in vtkVolumeShaderComposer.h) marches from a sample
    towards the light in texture coordinates with the view ray's step length in texture
    coordinates, and takes each step's opacity as that of a world step d. Texture coordinates
    scale each axis by its side, so in a box that is not a cube a step of the same texture
    length is a different world length in another direction: on the engine (2 x 2 x 1) under
    the chart's sun and camera, the shadows' optical depth would be 25 % too large. In a cube
    the scale is the same on every axis and every step is d."""
    sides = [n * s for n, s in zip(dims, spacing, strict=True)]
    longest = max(sides)
    return tuple(  # type: ignore[return-value]
        max(0, math.ceil(longest / s - 1e-6) - n) for n, s in zip(dims, spacing, strict=True)
    )


def void_value(scene: VtkScene) -> float:
    """A value whose extinction is 0, to pad with: the smallest value if it is void (the usual
    case: air around a CT), else a control point of sigma_t 0, else one just below the data's
    range, where VTK's opacity is set to 0 (:meth:`VtkRenderer.volume_property`)."""
    lo, hi = scene.value_range
    if _sigma(scene, np.array([lo]))[0] <= 0.0:
        return lo
    void = [p[0] for p in scene.points if p[1] <= 0.0]
    if void:
        return min(void, key=lambda v: abs(v - lo))
    return lo - max(hi - lo, 1.0) / TF_SAMPLES


def _sigma(scene: VtkScene, values: npt.NDArray[np.float64]) -> npt.NDArray[np.float64]:
    """Occlux's sigma_t on raw values: piecewise linear through the control points, clamped
    at the ends (src/classify: the baked table is read with linear interpolation)."""
    xs = np.array([p[0] for p in scene.points])
    return np.interp(values, xs, np.array([p[1] for p in scene.points]))


def _albedo(scene: VtkScene, values: npt.NDArray[np.float64]) -> npt.NDArray[np.float64]:
    xs = np.array([p[0] for p in scene.points])
    return np.stack(
        [np.interp(values, xs, np.array([p[2][c] for p in scene.points])) for c in range(3)],
        axis=-1,
    )


def tf_values(scene: VtkScene, pad: float) -> npt.NDArray[np.float64]:
    """Where VTK's transfer functions get a point: evenly over the data's range (with the
    padding value) and at each of Occlux's control points inside it."""
    lo, hi = scene.value_range
    lo, hi = min(lo, pad), max(hi, pad)
    xs = np.linspace(lo, hi, TF_SAMPLES) if hi > lo else np.array([lo])
    inside = [p[0] for p in scene.points if lo < p[0] < hi]
    return np.unique(np.concatenate([xs, inside]))


@dataclass(frozen=True)
class Setting:
    """One point of VTK's quality axis: the sample distance in voxels of the smallest spacing,
    and whether shadows are on (global illumination reach 1) or off (0)."""

    label: str
    step_voxels: float
    shadows: bool = True


def settings_for(estimator: str) -> list[Setting]:
    """The chart's settings: sample distances of 1, 0.5 and 0.25 voxel with shadows, and, under
    suns and lamps, the finest without them (how much the shadows are worth)."""
    lit = estimator != "ambient"
    shadow = "shadows on" if lit else "no ambient occlusion"
    points = [Setting(f"step {s} voxel, {shadow}", s, lit) for s in (1.0, 0.5, 0.25)]
    if lit:
        points.append(Setting("step 0.25 voxel, shadows off", 0.25, False))
    return points


# ---------------------------------------------------------------------------------------------
# The renderer


class VtkRenderer:
    """An offscreen VTK window set up for one scene: camera, lights, a float32 framebuffer.

    VTK's window renders into its own framebuffer object of 8-bit colour, which would clamp
    radiance to [0, 1] and quantise it to 1/255. After the first render (which creates it) its
    colour attachment is replaced by a float32 texture (``PopulateFramebuffer`` with VTK_FLOAT)
    and pixels are read as floats (``GetRGBAPixelData``). (A ``vtkFramebufferPass`` with a float
    format would be the documented way, but the GPU ray caster draws nothing inside it in VTK
    9.7.)"""

    def __init__(self, scene: VtkScene, estimator: str, g: float = 0.0) -> None:
        self.vtk = vtk_modules()
        self.scene = scene
        self.estimator = estimator
        self.g = g
        self.lit = estimator != "ambient"
        dims = scene.values.shape[::-1]
        self.padding = cube_padding(dims, scene.spacing)
        self.pad_value = void_value(scene)
        self._check_lamps()
        self.light_scale = self._light_scale()
        v = self.vtk
        cam = scene.camera
        self.window = v["vtkRenderWindow"]()
        self.window.SetOffScreenRendering(1)
        self.window.SetMultiSamples(0)
        self.window.SetSize(cam.width, cam.height)
        self.renderer = v["vtkRenderer"]()
        self.renderer.SetBackground(0.0, 0.0, 0.0)
        self.renderer.SetBackgroundAlpha(0.0)
        self.window.AddRenderer(self.renderer)
        self._camera()
        self._lights()
        self.window.Render()
        framebuffer = self.window.GetRenderFramebuffer()
        self.window.MakeCurrent()
        framebuffer.Bind()
        framebuffer.PopulateFramebuffer(
            cam.width, cam.height, True, 1, v["VTK_FLOAT"], True, 32, 0, False
        )
        framebuffer.UnBind()

    def _check_lamps(self) -> None:
        """VTK weighs a lamp by ``pow(cos(angle to its axis), exponent)``, which GLSL leaves
        undefined for a negative cosine: a lamp is aimed at the box's centre and must lie
        outside the box's bounding sphere, so that every sample is within 90 degrees of it."""
        lo, hi = self.box()
        centre, radius = 0.5 * (lo + hi), 0.5 * float(np.linalg.norm(hi - lo))
        for light in self.scene.lights:
            if light.kind == "point" and np.linalg.norm(np.asarray(light.vector) - centre) <= (
                radius
            ):
                raise VtkPeerError(
                    f"{self.scene.label}: the lamp at {light.vector} is within the volume's "
                    "bounding sphere; VTK's positional lights (cone weighting) cannot light "
                    "a volume from inside"
                )

    def _light_scale(self) -> float:
        """k >= 1 such that every sample's shaded colour with the lights divided by k is at most
        1: VTK clamps each sample's colour to [0, 1] (``computeColor`` in
        vtkVolumeShaderComposer.h), before compositing, so the lights are dimmed by k and the
        image brightened by k. The bound: the largest albedo times the sum over lights of
        intensity / (4 pi) times the phase function's peak (VTK's 4 pi-normalised
        Henyey-Greenstein: (1 + |g|) / (1 - |g|)^2) times, for a lamp, 1 / r^2 at the box."""
        if not self.lit:
            return 1.0
        albedo = max(max(p[2]) for p in self.scene.points)
        g = abs(self.g)
        phase = (1.0 + g) / (1.0 - g) ** 2
        lo, hi = self.box()
        total = 0.0
        for light in self.scene.lights:
            weight = max(light.rgb) / (4.0 * math.pi)
            if light.kind == "point":
                nearest = np.clip(np.asarray(light.vector), lo, hi)
                weight /= max(float(np.sum((np.asarray(light.vector) - nearest) ** 2)), 1e-12)
            total += weight
        return max(1.0, albedo * phase * total)

    def box(self) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]]:
        """The padded image's box in world units (cells)."""
        spacing = np.asarray(self.scene.spacing)
        lo = np.asarray(self.scene.origin) - 0.5 * spacing
        dims = np.asarray(self.scene.values.shape[::-1]) + np.asarray(self.padding)
        return lo, lo + dims * spacing

    def _camera(self) -> None:
        cam = self.scene.camera
        camera = self.renderer.GetActiveCamera()
        position = np.asarray(cam.position)
        forward = np.asarray(cam.forward)
        camera.SetPosition(*position)
        camera.SetFocalPoint(*(position + forward))
        camera.SetViewUp(*cam.up)
        if cam.perspective:
            camera.ParallelProjectionOff()
            camera.SetViewAngle(math.degrees(cam.fov_y))
        else:
            camera.ParallelProjectionOn()
            camera.SetParallelScale(cam.half_height)
        lo, hi = self.box()
        corners = np.array(
            [[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1]) for z in (lo[2], hi[2])]
        )
        depths = (corners - position) @ forward
        far = max(float(depths.max()) * 1.01, 1e-3)
        near = max(float(depths.min()) * 0.99, far * 1e-4)
        if not cam.perspective:
            near = float(depths.min()) - 0.01 * far
        camera.SetClippingRange(near, far)

    def _lights(self) -> None:
        """Suns as directional scene lights, lamps as positional ones aimed at the box's centre
        with 1 / r^2 attenuation and no cone, each of intensity (irradiance or radiant
        intensity) / (4 pi) for VTK's unnormalised phase function."""
        v = self.vtk
        self.renderer.AutomaticLightCreationOff()
        self.renderer.RemoveAllLights()
        lo, hi = self.box()
        centre = 0.5 * (lo + hi)
        for light in self.scene.lights:
            peak = max(light.rgb)
            if peak <= 0.0:
                continue
            vtk_light = v["vtkLight"]()
            vtk_light.SetLightTypeToSceneLight()
            vtk_light.SetColor(*(c / peak for c in light.rgb))
            vtk_light.SetIntensity(peak / (4.0 * math.pi) / self.light_scale)
            if light.kind == "directional":
                vtk_light.SetPositional(False)
                vtk_light.SetFocalPoint(0.0, 0.0, 0.0)
                vtk_light.SetPosition(*light.vector)
            else:
                vtk_light.SetPositional(True)
                vtk_light.SetPosition(*light.vector)
                vtk_light.SetFocalPoint(*centre)
                vtk_light.SetConeAngle(180.0)
                vtk_light.SetExponent(0.0)
                vtk_light.SetAttenuationValues(0.0, 0.0, 1.0)
            self.renderer.AddLight(vtk_light)

    def image_data(self):
        """The padded vtkImageData with the values as cell scalars (see the module docs)."""
        v = self.vtk
        values = self.scene.values
        px, py, pz = self.padding
        if px or py or pz:
            values = np.pad(
                values, ((0, pz), (0, py), (0, px)), mode="constant", constant_values=self.pad_value
            )
        nz, ny, nx = values.shape
        image = v["vtkImageData"]()
        image.SetDimensions(nx + 1, ny + 1, nz + 1)
        spacing = np.asarray(self.scene.spacing)
        image.SetOrigin(*(np.asarray(self.scene.origin) - 0.5 * spacing))
        image.SetSpacing(*spacing)
        scalars = v["numpy_to_vtk"](np.ascontiguousarray(values).ravel(), deep=1)
        scalars.SetName("value")
        image.GetCellData().SetScalars(scalars)
        return image

    def volume_property(self, step: float):
        """Transfer functions at sample distance ``step`` (the opacity unit distance)."""
        v = self.vtk
        xs = tf_values(self.scene, self.pad_value)
        opacity = -np.expm1(-_sigma(self.scene, xs) * step)
        # Below the data's range only the padding lives: void whatever Occlux's function says.
        opacity[xs < self.scene.value_range[0]] = 0.0
        albedo = _albedo(self.scene, xs)
        scalar_opacity = v["vtkPiecewiseFunction"]()
        colour = v["vtkColorTransferFunction"]()
        for x, a, rgb in zip(xs, opacity, albedo, strict=True):
            scalar_opacity.AddPoint(float(x), float(a))
            colour.AddRGBPoint(float(x), *(float(c) for c in rgb))
        prop = v["vtkVolumeProperty"]()
        prop.SetScalarOpacity(scalar_opacity)
        prop.SetColor(colour)
        prop.SetScalarOpacityUnitDistance(step)
        prop.SetInterpolationTypeToLinear()
        prop.SetIndependentComponents(True)
        if self.lit:
            prop.ShadeOn()
            prop.SetAmbient(0.0)
            prop.SetDiffuse(1.0)
            prop.SetSpecular(0.0)
            prop.SetScatteringAnisotropy(self.g)
        else:
            prop.ShadeOff()
        return prop

    def step(self, setting: Setting) -> float:
        return setting.step_voxels * min(self.scene.spacing)

    def render(self, setting: Setting) -> npt.NDArray[np.float32]:
        """One render from the loaded volume: image data, transfer functions, a fresh volume and
        mapper (the texture upload), the ray cast and the read-back; linear RGB, row 0 at the
        top, Occlux's background composited."""
        v = self.vtk
        step = self.step(setting)
        mapper = v["Mapper"]()
        mapper.SetInputData(self.image_data())
        mapper.SetAutoAdjustSampleDistances(False)
        mapper.SetSampleDistance(step)
        mapper.SetUseJittering(False)
        if self.lit:
            mapper.SetVolumetricScatteringBlending(1.0)
            mapper.SetGlobalIlluminationReach(1.0 if setting.shadows else 0.0)
        volume = v["vtkVolume"]()
        volume.SetMapper(mapper)
        volume.SetProperty(self.volume_property(step))
        self.renderer.AddVolume(volume)
        try:
            self.window.Render()
            rgba = self.read()
        finally:
            self.renderer.RemoveVolume(volume)
            mapper.ReleaseGraphicsResources(self.window)
        scale = np.asarray(self.scene.ambient) if not self.lit else np.full(3, self.light_scale)
        alpha = rgba[..., 3:4]
        rgb = rgba[..., :3] * scale + (1.0 - alpha) * np.asarray(self.scene.background)
        return np.ascontiguousarray(rgb, dtype=np.float32)

    def read(self) -> npt.NDArray[np.float32]:
        """The float framebuffer as (height, width, 4), row 0 at the top."""
        v = self.vtk
        w, h = self.scene.camera.width, self.scene.camera.height
        pixels = v["vtkFloatArray"]()
        self.window.GetRGBAPixelData(0, 0, w - 1, h - 1, 0, pixels, 0)
        return v["vtk_to_numpy"](pixels).reshape(h, w, 4)[::-1].astype(np.float32)


def render_curve(
    scene_path: str | os.PathLike[str],
    estimator: str,
    out: str | os.PathLike[str],
    g: float = 0.0,
    settings: Sequence[Setting] | None = None,
) -> dict[str, Any]:
    """Renders the scene at each of VTK's settings (:func:`settings_for` unless given), writes
    ``OUT/vtk-ESTIMATOR-N.exr`` per setting and the curve JSON, and returns the JSON's content."""
    scene_path, out = Path(scene_path), Path(out)
    scene = load_scene(scene_path, estimator)
    g = 0.0 if estimator == "ambient" else g
    if not -1.0 < g < 1.0:
        raise VtkPeerError(f"g = {g}: the Henyey-Greenstein asymmetry must be in (-1, 1)")
    out.mkdir(parents=True, exist_ok=True)
    renderer = VtkRenderer(scene, estimator, g)
    settings = list(settings) if settings is not None else settings_for(estimator)
    renderer.render(settings[-1])  # warm-up: shader compilation
    points: list[CurvePoint] = []
    for i, setting in enumerate(settings):
        times = []
        image = None
        for _ in range(REPEATS):
            started = time.perf_counter()
            image = renderer.render(setting)
            times.append(time.perf_counter() - started)
        assert image is not None
        exr = out / f"{PEER}-{estimator}-{i}.exr"
        write_exr_layers(exr, {"beauty": image})
        point: CurvePoint = {
            "setting": setting.label,
            "seconds": statistics.median(times),
            "exr": str(exr),
        }
        if not setting.shadows:
            point["series"] = "no shadows"  # off the axis of sample distances
        points.append(point)
    lo, hi = renderer.box()
    extra = {
        "version": renderer.vtk["version"],
        "g": g,
        "mapping": {
            "renderer": "vtkOpenGLGPUVolumeRayCastMapper, composite blend, cell data, "
            "linear interpolation, no jittering",
            "sample_distances": [renderer.step(s) for s in settings],
            "opacity": "1 - exp(-sigma_t * d), unit distance d = the sample distance",
            "colour": "albedo",
            "lights": (
                "ambient: shading off, image x ambient radiance (VTK has no ambient occlusion "
                "for volumes: this is unshaded emission-absorption)"
                if estimator == "ambient"
                else "volumetric scattering blending 1 (no surface shading), intensity = "
                "irradiance / (4 pi) for suns, radiant intensity / (4 pi) with 1/r^2 for lamps; "
                "shadows: global illumination reach 1 (one side of the padded cube) or 0"
            ),
            "scattering": "single" if estimator != "ambient" else "none (ambient term only)",
            "padding": {"cells": list(renderer.padding), "value": renderer.pad_value},
            "box": [lo.tolist(), hi.tolist()],
            "framebuffer": "float32 colour attachment, background composited afterwards",
            "light_scale": renderer.light_scale,
        },
    }
    if estimator == "multiple":
        extra["note"] = "VTK has no multiple scattering: these are single-scattering images"
    if estimator == "ambient":
        extra["note"] = "VTK has no ambient occlusion for volumes: ambient term without occlusion"
    return write_curve(out, PEER, estimator, scene_path, points, TIMING, extra)


def main(argv: Sequence[str] | None = None) -> int:
    args = parser(
        "python -m occlux_lab.peers.vtk",
        "Render an Occlux scene with VTK's GPU volume ray caster at several sample distances "
        "(a peer series of occlux chart).",
    ).parse_args(argv)
    try:
        report = render_curve(args.scene, args.estimator, args.out, args.g)
    except OccluxError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    for point in report["points"]:
        print(f"VTK {point['setting']:<36} {point['seconds']:.3f} s -> {point['exr']}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
