"""Cross-check of Occlux's Monte Carlo references against Blender's Cycles.

Given an Occlux scene, this package builds the same scene in Blender 5 (as a Python module or
inside Blender): the volume from the ``value`` grid that ``occlux.export`` writes, mapped through
the scene's 1D transfer function onto a Principled Volume, and the camera, lights and world of
one of Occlux's estimators, all as the core resolved them (:meth:`occlux.Scene.describe`,
:meth:`occlux.Classification.raw_points`); renders it with Cycles at several seeds; and compares
the result with ``occlux.reference``'s image pixel by pixel, in units of the combined standard
error. Occlux runs in the same process. The conventions it relies on, and how each was verified,
are in docs/cycles-mapping.md.

Its parts: :mod:`.scene` (what Cycles needs of a scene), :mod:`.material` (the shader node
trees), :mod:`.blender` (the Blender scene, the camera check, the renders), :mod:`.stats` (z
scores, the report, the error map), :mod:`.images` (reading images, writing the outputs with the
core's writers), :mod:`.check` (the whole check) and :mod:`.cli` (the command line).

From a shell (what ``occlux check-cycles`` runs)::

    python -m occlux.cycles examples/engine.toml --estimator single --spp 256 --out check/

From Python::

    import occlux.cycles as oc

    cycles = oc.render_cycles("engine.toml", "out/engine.vdb", "single", spp=256, seeds=16)
    report = oc.compare(oc.read_reference("out/engine-single.exr"), cycles.mean, cycles.stderr)
    print(report.table())
"""

from occlux.cycles.blender import (
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
)
from occlux.cycles.bundled import bpy_site_packages, bundled_module
from occlux.cycles.check import Check, check
from occlux.cycles.cli import EXIT_DISAGREE, main
from occlux.cycles.common import (
    CYCLES_FIRST_SEED,
    DEFAULT_BOUNCES,
    DEFAULT_SEEDS,
    ESTIMATORS,
    OCCLUX_SEED,
    HarnessError,
    Rgb,
)
from occlux.cycles.images import OccluxImage, read_channels, read_reference, write_outputs
from occlux.cycles.material import PREFIX
from occlux.cycles.scene import (
    MAX_RAMP_STOPS,
    CameraSpec,
    LightSpec,
    SceneSpec,
    TfPoint,
    load_scene,
)
from occlux.cycles.stats import (
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
    "EXIT_DISAGREE",
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
    "Check",
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
    "check",
    "check_camera",
    "compare",
    "cycles_settings",
    "error_map",
    "linear_exr_output",
    "load_scene",
    "main",
    "placed_value_grid",
    "read_channels",
    "read_reference",
    "remove_built",
    "render_cycles",
    "render_scene",
    "render_seeds",
    "write_outputs",
    "z_scores",
]
