"""Blender's EEVEE as a peer of ``occlux chart``: what Blender users preview a volume with.

``python -m occlux_lab.peers.eevee SCENE --estimator single --out DIR`` builds the Occlux scene as a
Blender scene through the Cycles mapping (:func:`occlux.blender.cycles.build_blender_scene`:
the ``value`` grid as a Volume object, the transfer function as a Principled Volume masked to
the volume's box, the camera, the suns and lamps, the world of the estimator), switches the
engine to EEVEE with its volume settings (:func:`eevee_settings`) and renders it at each
setting of :data:`LADDER`, EEVEE's quality axis from cheap to best. It writes
``DIR/eevee-ESTIMATOR-N-NAME.exr`` per setting (linear RGB, float32, the camera's size) and
``DIR/eevee-ESTIMATOR-curve.json`` (:func:`occlux_lab.peers.common.write_curve`).

What EEVEE can and cannot render of Occlux's model (measured; docs/peers-eevee.md):

- Single scattering of suns and lamps, the volume shadowing them only with shadow maps on
  (USE_SHADOW_MAPS), and then too weakly (the engine under a sun: +20 % at the finest setting).
- An orthographic camera under a sun renders black (its shadow cascades): refused.
- World light reaches the volume through the world's spherical harmonics, but no volume
  shadows it: the ``ambient`` image is the in-scattering of an unoccluded sky, too bright inside.
- No multiple scattering: ``multiple`` is rendered as single scattering.
- The volume is resolved on a froxel grid (``volumetric_tile_size`` pixels across,
  ``volumetric_samples`` slices in depth between :func:`depth_range`'s near and far) and
  averaged over ``taa_render_samples`` jittered renders.

Time: one process renders every setting. The first render compiles EEVEE's shaders (tens of
seconds to minutes on Mesa's llvmpipe, seconds on a GPU), so one warm-up render at the
cheapest setting comes first and is not timed; each setting's time is the median of its
renders (:func:`render_curve`).
"""

from __future__ import annotations

import os
import statistics
import sys
import tempfile
from collections.abc import Sequence
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import numpy as np
from occlux._occlux import OccluxError, Scene, write_vdb
from occlux.blender.common import DEFAULT_BOUNCES, HarnessError, effective_options
from occlux.blender.cycles import (
    bpy_module,
    build_blender_scene,
    linear_exr_output,
    render_still,
)
from occlux.blender.scene import CameraSpec, SceneSpec

from .common import CurvePoint, parser, write_curve

PEER = "eevee"
ENGINE = "BLENDER_EEVEE"
"""EEVEE's engine id in Blender 5 (EEVEE Next; the legacy engine is gone)."""


@dataclass(frozen=True)
class Quality:
    """One setting of EEVEE's quality axis: froxel size in pixels, depth slices, steps of each
    volume shadow ray, and anti-aliasing samples (each re-jitters the froxel grid)."""

    name: str
    tile_size: str
    samples: int
    shadow_samples: int
    taa_samples: int

    @property
    def setting(self) -> str:
        """The setting in words, as the chart shows it."""
        return (
            f"{self.name}: {self.tile_size} px froxels, {self.samples} slices, "
            f"{self.shadow_samples} shadow steps, {self.taa_samples} samples"
        )


LADDER: tuple[Quality, ...] = (
    Quality("coarse", "8", 32, 8, 2),
    Quality("medium", "4", 64, 16, 8),
    Quality("fine", "2", 128, 32, 16),
    Quality("finest", "1", 256, 64, 32),
)
"""EEVEE's quality axis, cheap to best (``--ladder`` picks settings by name). Froxels are sized in
pixels, so what a setting resolves depends on the image: at the chart's 128^2 an 8-pixel froxel
is 1/16 of the image (Blender's default), a 1-pixel one Occlux's resolution. Blender's default
render samples (64) are beyond the ladder: on llvmpipe every sample re-renders the shadow maps
(about 2 s at 32^2). A 16-pixel froxel with one sample rendered nothing at all on a 32^2 image
(measured), so the ladder starts at 8 pixels and 2 samples."""

DEFAULT_LADDER = ("coarse", "medium", "fine")
"""The settings rendered unless ``--ladder`` names others: "finest" (1-pixel froxels, 32
samples) takes about five minutes per render at 128^2 on llvmpipe, too long for a chart of many
scenes; ask for it by name."""


def ladder_of(names: Sequence[str]) -> tuple[Quality, ...]:
    """The settings of :data:`LADDER` called ``names``, in the ladder's order."""
    known = {q.name for q in LADDER}
    unknown = [n for n in names if n not in known]
    if unknown or not names:
        raise HarnessError(
            f"unknown EEVEE settings {unknown or list(names)}; known: {', '.join(sorted(known))}"
        )
    return tuple(q for q in LADDER if q.name in names)


DEPTH_MARGIN = 0.01
"""The froxel grid spans the volume's box in depth, widened by this fraction on each side so that
no slice's jitter leaves the box's faces outside it."""


def depth_range(
    camera: CameraSpec, box: tuple[Sequence[float], Sequence[float]]
) -> tuple[float, float]:
    """Near and far distance along the camera's view axis that hold the volume's ``box``: the
    least and greatest depth of its eight corners, widened by DEPTH_MARGIN, near kept in front of
    the eye (a camera inside the box starts the grid at 1e-3 of the far distance). EEVEE spreads
    its depth slices over this range only, so a tight range is its depth resolution."""
    lo, hi = np.asarray(box[0], float), np.asarray(box[1], float)
    corners = np.array([[(lo, hi)[(k >> a) & 1][a] for a in range(3)] for k in range(8)])
    depths = (corners - np.asarray(camera.position)) @ np.asarray(camera.forward)
    near, far = float(depths.min()), float(depths.max())
    if far <= 0.0:
        raise HarnessError("the volume lies behind the camera: EEVEE has nothing to render")
    span = far - near
    far += DEPTH_MARGIN * span
    near = max(near - DEPTH_MARGIN * span, 1e-3 * far)
    return near, far


USE_SHADOW_MAPS = True
"""Whether EEVEE renders shadow maps: there are no surfaces, but without them the volume does
not shadow itself at all (measured on the CT phantom under a sun, 32^2, 2-pixel froxels: +107 %
bias against Occlux's single scattering without, +28 % with; ``volumetric_shadow_samples`` made
no difference without them). They cost most of a render on llvmpipe (2.7x at 32^2)."""

CLIP_MARGIN = 2.0
"""The camera's clip range for EEVEE: the volume's depth range from :func:`depth_range` widened
by this factor each way. The Cycles mapping's camera clips at 1e-4 and 1e8 (Cycles has no depth
buffer); EEVEE's depth buffer at that ratio loses the volume entirely (measured: a black
image)."""


def eevee_settings(scene, spec: SceneSpec) -> dict[str, Any]:
    """Switches a built scene to EEVEE with the settings that make its volume Occlux's as far as
    EEVEE can, and no surface feature that only costs time; returns them (for the curve's JSON).

    - ``light_threshold = 0``: lamps light the volume at any distance (the default 0.01 cuts
      their influence where their irradiance falls below it).
    - ``clamp_volume_direct = clamp_volume_indirect = 0``, ``volumetric_light_clamp = 0``: no
      clamp of the volume's light.
    - ``use_volumetric_shadows``: the volume shadows the lights (with shadow maps on).
    - A custom volume range from :func:`depth_range`, slices spaced evenly in depth
      (distribution 0): the grid covers the volume's box and nothing else.
    - The film filter at 0.01 pixel (:func:`occlux.blender.cycles.linear_exr_output`): Occlux's
      rays go through pixel centres.
    - The camera's clip range around the volume (CLIP_MARGIN): EEVEE has a depth buffer.
    - No raytracing, no fast GI, no motion blur (there are no surfaces); shadow maps on, as the
      volume's self-shadowing needs them (USE_SHADOW_MAPS).
    - The material's output node for every engine (the Cycles mapping targets Cycles).
    """
    if not spec.camera.perspective and any(light.type == "SUN" for light in lights(scene)):
        raise HarnessError(
            f"{spec.label}: an orthographic camera under a sun renders black in EEVEE (its sun "
            "shadows use cascades there); use a perspective camera"
        )
    scene.render.engine = ENGINE
    linear_exr_output(scene)
    e = scene.eevee
    near, far = depth_range(spec.camera, spec.box)
    settings: dict[str, Any] = {
        "light_threshold": 0.0,
        "clamp_volume_direct": 0.0,
        "clamp_volume_indirect": 0.0,
        "volumetric_light_clamp": 0.0,
        "use_volumetric_shadows": True,
        "use_volume_custom_range": True,
        "volumetric_start": near,
        "volumetric_end": far,
        "volumetric_sample_distribution": 0.0,
        "use_raytracing": False,
        "use_fast_gi": False,
        "use_shadows": USE_SHADOW_MAPS,
    }
    for key, value in settings.items():
        setattr(e, key, value)
    camera = scene.camera.data
    camera.clip_start = near / CLIP_MARGIN
    camera.clip_end = far * CLIP_MARGIN
    settings["camera_clip"] = [camera.clip_start, camera.clip_end]
    # The Cycles mapping's material targets Cycles' output only; EEVEE would render nothing.
    for obj in scene.collection.objects:
        if obj.type == "VOLUME":
            for material in obj.data.materials:
                for node in material.node_tree.nodes:
                    if node.bl_idname == "ShaderNodeOutputMaterial":
                        node.target = "ALL"
    if scene.world is not None and hasattr(scene.world, "sun_threshold"):
        # A uniform sky has no sun to extract into a shadowed light; keep it all as sky light.
        scene.world.sun_threshold = 1e9
        settings["world_sun_threshold"] = 1e9
    settings["film_filter_px"] = scene.render.filter_size
    return settings


def lights(scene) -> list[Any]:
    """The lamps of a built scene (their data)."""
    return [obj.data for obj in scene.collection.objects if obj.type == "LIGHT"]


def apply_quality(scene, quality: Quality) -> None:
    """Sets one setting of the quality axis."""
    e = scene.eevee
    e.volumetric_tile_size = quality.tile_size
    e.volumetric_samples = quality.samples
    e.volumetric_shadow_samples = quality.shadow_samples
    e.taa_render_samples = quality.taa_samples


def _slug(index: int, quality: Quality) -> str:
    return f"{index}-{quality.name}"


REPEAT_BELOW_S = 10.0
"""A setting whose first timed render took less than this is rendered ``repeats`` times (the
median is its time); a slower one once."""


def render_curve(
    scene_path: str | os.PathLike[str],
    estimator: str,
    out: str | os.PathLike[str],
    bounces: int = DEFAULT_BOUNCES,
    g: float = 0.0,
    *,
    ladder: Sequence[Quality] | None = None,
    repeats: int = 3,
) -> dict[str, Any]:
    """Renders the scene with EEVEE at each setting of ``ladder`` (cheap to best; those of
    DEFAULT_LADDER unless given) and writes the
    images and the curve JSON into ``out`` (see the module docs); returns what the JSON holds.

    The volume is written to a temporary VDB, the Blender scene built once, then one warm-up
    render at the cheapest setting compiles EEVEE's shaders and uploads the grid (not timed).
    Each setting is then rendered ``repeats`` times if its first render is quicker than
    REPEAT_BELOW_S, else once, and timed by the median; every render redoes what an EEVEE final
    render does (its render engine, the volume's froxel grid, the lights, every TAA sample,
    writing the EXR), nothing of the scene is rebuilt between them."""
    ladder = ladder_of(DEFAULT_LADDER) if ladder is None else ladder
    if not ladder:
        raise HarnessError("the quality ladder is empty")
    if repeats < 1:
        raise HarnessError(f"repeats must be at least 1, got {repeats}")
    scene_path, out = Path(scene_path), Path(out)
    bounces, g = effective_options(estimator, bounces, g)
    core = Scene.load(scene_path)
    volume, _ = core.settle()
    bpy = bpy_module()
    out.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(prefix="occlux-eevee-") as tmp:
        vdb = Path(tmp) / f"{scene_path.stem}.vdb"
        write_vdb(vdb, {"value": volume})
        blender_scene, spec = build_blender_scene(core, vdb, estimator, bounces, g, volume=volume)
        settings = eevee_settings(blender_scene, spec)
        apply_quality(blender_scene, ladder[0])
        warmup = render_still(blender_scene, Path(tmp) / "warmup.exr", "EEVEE render")
        points: list[CurvePoint] = []
        renders: list[int] = []
        for index, quality in enumerate(ladder):
            apply_quality(blender_scene, quality)
            exr = out / f"{PEER}-{estimator}-{_slug(index, quality)}.exr"
            times = [render_still(blender_scene, exr, "EEVEE render")]
            if times[0] < REPEAT_BELOW_S:
                times += [
                    render_still(blender_scene, exr, "EEVEE render") for _ in range(repeats - 1)
                ]
            points.append(
                {"setting": quality.setting, "seconds": statistics.median(times), "exr": str(exr)}
            )
            renders.append(len(times))
    timing = (
        "wall time of one EEVEE final render of the built scene (bpy.ops.render.render: render "
        "engine, froxel grid, lights, every TAA sample) and writing its EXR; median of "
        f"{repeats} renders per setting (1 where a render took over {REPEAT_BELOW_S:g} s), "
        "after one untimed warm-up render that compiles EEVEE's shaders and uploads the grid; "
        "the scene build and VDB export are not included"
    )
    extra = {
        "blender": bpy.app.version_string,
        "engine": ENGINE,
        "device": _device(bpy),
        "bounces": bounces,
        "g": g,
        "scattering": "single (EEVEE has no multiple scattering)",
        "world_light_shadowed": False,
        "eevee": settings,
        "ladder": [asdict(q) for q in ladder],
        "renders_per_setting": renders,
        "warmup_seconds": warmup,
    }
    return write_curve(out, PEER, estimator, scene_path, points, timing, extra)


def _device(bpy) -> str:
    """The GPU EEVEE ran on, as Blender names it (``llvmpipe`` for Mesa's software driver)."""
    try:
        import gpu

        return f"{gpu.platform.vendor_get()} {gpu.platform.renderer_get()}"
    except Exception:  # only a label for the JSON
        return "unknown"


def main(argv: Sequence[str] | None = None) -> int:
    p = parser(
        "python -m occlux_lab.peers.eevee",
        "Render an Occlux scene with Blender's EEVEE at several quality settings "
        "(a peer series of occlux chart).",
    )
    p.add_argument(
        "--ladder",
        default=",".join(DEFAULT_LADDER),
        help=f"settings, comma-separated, of: {', '.join(q.name for q in LADDER)}",
    )
    args = p.parse_args(argv)
    try:
        ladder = ladder_of(args.ladder.split(","))
        report = render_curve(
            args.scene, args.estimator, args.out, args.bounces, args.g, ladder=ladder
        )
    except OccluxError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    for point in report["points"]:
        print(f"EEVEE {point['setting']}: {point['seconds']:.2f} s -> {point['exr']}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
