"""The add-on's operators, one module per family: `volume` (load a volume, compute its ambient
occlusion), `bake` (Bake Light: the scene's light baked into grids and a material that emits
it), `classify` (Suggest from File and Apply Classification: the panel's transfer function
onto the active volume), `render` (method renders: DOS and IPSVI), `check` (the check against
Cycles), `composite` (an Occlux EXR layer in the compositor), `stage` (Import Occlux Stage: a
USD stage with its render size and camera, also in File > Import) and `series` (Load Series:
the VDBs of `occlux series` as one animated Volume object). The long ones are jobs, framed by
`jobs` (progress, background thread, cancel). Each checks its input first and creates nothing
when it fails."""

from __future__ import annotations

import bpy

from . import bake, check, classify, composite, jobs, render, series, stage, volume

CLASSES = (
    volume.CLASSES
    + bake.CLASSES
    + classify.CLASSES
    + series.CLASSES
    + render.CLASSES
    + check.CLASSES
    + composite.CLASSES
    + stage.CLASSES
)


def register() -> None:
    for cls in CLASSES:
        bpy.utils.register_class(cls)
    bpy.types.TOPBAR_MT_file_import.append(stage.menu_import)


def unregister() -> None:
    jobs.cancel_all()
    bpy.types.TOPBAR_MT_file_import.remove(stage.menu_import)
    for cls in reversed(CLASSES):
        bpy.utils.unregister_class(cls)
