"""The add-on's operators, one module per family: `volume` (load a volume, compute its ambient
occlusion), `render` (method renders: DOS and IPSVI), `check` (the check against Cycles) and
`composite` (an Occlux EXR layer in the compositor). The long ones are jobs, framed by `jobs`
(progress, background thread, cancel). Each checks its input first and creates nothing when it
fails."""

from __future__ import annotations

import bpy

from . import check, composite, jobs, render, volume

CLASSES = volume.CLASSES + render.CLASSES + check.CLASSES + composite.CLASSES


def register() -> None:
    for cls in CLASSES:
        bpy.utils.register_class(cls)


def unregister() -> None:
    jobs.cancel_all()
    for cls in reversed(CLASSES):
        bpy.utils.unregister_class(cls)
