"""Occlux scenes in Blender, rendered with Cycles: what the add-on's Check Against Cycles runs.

Given an Occlux scene, this package builds the same scene in Blender 5 (as a Python module or
inside Blender): the volume from the ``value`` grid that ``occlux.export`` writes, mapped through
the scene's 1D transfer function onto a Principled Volume, and the camera, lights and world of
one of Occlux's estimators, all as the core resolved them (:meth:`occlux.Scene.describe`,
:meth:`occlux.Classification.raw_points`); renders it with Cycles at several seeds; and compares
the result with ``occlux.reference``'s image pixel by pixel, in units of the combined standard
error. The conventions it relies on, and how each was verified, are in docs/cycles-mapping.md.
It needs Blender (``bpy``) only when it builds or renders; importing it does not.

Its parts: :mod:`.scene` (what Cycles needs of a scene), :mod:`.material` (the shader node
trees, which the add-on's volume material uses too), :mod:`.cycles` (the Blender scene, the
camera check, the renders), :mod:`.stats` (z scores, the report, the error map), :mod:`.images`
(reading images, writing the outputs with the core's writers) and :mod:`.bundled` (the modules
Blender bundles: OpenImageIO, OpenVDB).

From Python::

    import occlux.blender as ob

    cycles = ob.render_cycles("engine.toml", "out/engine.vdb", "single", spp=256, seeds=16)
    report = ob.compare(ob.read_reference("out/engine-single.exr"), cycles.mean, cycles.stderr)
    print(report.table())

The measurement harness built on it (``occlux check-cycles``, the curves of ``occlux chart``)
is ``occlux_lab`` in the repository (lab/python), not part of this package.
"""

from occlux.blender.bundled import bpy_site_packages, bundled_module
from occlux.blender.common import (
    CYCLES_FIRST_SEED,
    DEFAULT_BOUNCES,
    DEFAULT_SEEDS,
    ESTIMATORS,
    OCCLUX_SEED,
    HarnessError,
    Rgb,
)
from occlux.blender.cycles import (
    SEQUENCE_LENGTH,
    CyclesImage,
    SeedDone,
    build_blender_scene,
    build_scene,
    camera_frustum,
    check_camera,
    cycles_settings,
    linear_exr_output,
    placed_value_grid,
    remove_built,
    render_cycles,
    render_scene,
    render_seeds,
    render_still,
)
from occlux.blender.images import OccluxImage, read_channels, read_reference, write_outputs
from occlux.blender.material import PREFIX
from occlux.blender.scene import (
    MAX_RAMP_STOPS,
    CameraSpec,
    LightSpec,
    SceneSpec,
    TfPoint,
    load_scene,
)
from occlux.blender.stats import (
    MASK_ALPHA,
    MAX_ABS_MEAN_Z,
    MAX_FRACTION_OVER_3,
    Z_CLIP,
    Z_SCALE_RANGE,
    Report,
    compare,
    error_map,
    z_scores,
)

__all__ = [
    "CYCLES_FIRST_SEED",
    "DEFAULT_BOUNCES",
    "DEFAULT_SEEDS",
    "ESTIMATORS",
    "MASK_ALPHA",
    "MAX_ABS_MEAN_Z",
    "MAX_FRACTION_OVER_3",
    "MAX_RAMP_STOPS",
    "OCCLUX_SEED",
    "PREFIX",
    "SEQUENCE_LENGTH",
    "Z_CLIP",
    "Z_SCALE_RANGE",
    "CameraSpec",
    "CyclesImage",
    "HarnessError",
    "LightSpec",
    "OccluxImage",
    "Report",
    "Rgb",
    "SceneSpec",
    "SeedDone",
    "TfPoint",
    "bpy_site_packages",
    "build_blender_scene",
    "build_scene",
    "bundled_module",
    "camera_frustum",
    "check_camera",
    "compare",
    "cycles_settings",
    "error_map",
    "linear_exr_output",
    "load_scene",
    "placed_value_grid",
    "read_channels",
    "read_reference",
    "remove_built",
    "render_cycles",
    "render_scene",
    "render_seeds",
    "render_still",
    "write_outputs",
    "z_scores",
]
