"""The panel's transfer function onto the volume: Suggest from File sets the window and the
ramp from the file's robust value range, as `occlux info --suggest` does, and Apply
Classification re-runs what the active Occlux volume holds (Bake Light if it is baked, else
Compute AO if it has an `ao` grid, else Load Volume), so that its grids and material show the
panel's classification."""

from __future__ import annotations

from pathlib import Path

import bpy
import occlux

from .. import scenes, transfer
from .bake import BAKED
from .volume import SOURCE


class OCCLUX_OT_suggest_classification(bpy.types.Operator):
    """Set the window to the file's robust value range and the ramp to the one `occlux info
    --suggest` suggests on it (the active Occlux volume's file, else the panel's Volume)"""

    bl_idname = "occlux.suggest_classification"
    bl_label = "Suggest from File"
    bl_options = {"REGISTER", "UNDO"}

    def execute(self, context: bpy.types.Context) -> set[str]:
        settings = context.scene.occlux
        try:
            source = scenes.selected_source(context)
            held = transfer.kept_by(scenes.dataset_object(context, source))
            if held is None:  # no object keeps it: read from the file itself
                tree = {"volume": source.section(), "camera": dict(scenes.UNUSED_CAMERA)}
                robust = scenes.load_volume(scenes.build(tree), source).robust_window()
            else:
                robust = held["robust"]
        except (OSError, ValueError, occlux.OccluxError) as e:
            self.report({"ERROR"}, str(e))
            return {"CANCELLED"}
        transfer.suggest(settings, robust)
        cut = "" if robust["cut"] is None else f", values above {robust['cut']:g} cut away"
        self.report(
            {"INFO"},
            f"window {robust['lo']:g} .. {robust['hi']:g} of {source.path.name} (background "
            f"{robust['background']:g}{cut}) with the suggested ramp: Apply Classification "
            "shows it",
        )
        return {"FINISHED"}


def rerun(obj: bpy.types.Object) -> str:
    """The operator that made what `obj` holds: Bake Light for a baked volume, Compute AO for
    one with an `ao` grid, else Load Volume."""
    if BAKED in obj:
        return "bake_light"
    obj.data.grids.load()  # a .blend opened afresh has not read the grids' names yet
    return "compute_ao" if "ao" in obj.data.grids else "import_volume"


class OCCLUX_OT_apply_classification(bpy.types.Operator):
    """Classify the active Occlux volume by the panel's transfer function: re-runs Bake Light
    if it is baked, else Compute AO if it has AO, else Load Volume"""

    bl_idname = "occlux.apply_classification"
    bl_label = "Apply Classification"
    bl_options = {"REGISTER", "UNDO"}

    def execute(self, context: bpy.types.Context) -> set[str]:
        return self.apply(context, "EXEC_DEFAULT")

    def invoke(self, context: bpy.types.Context, event: bpy.types.Event) -> set[str]:
        return self.apply(context, "INVOKE_DEFAULT")  # a background job, as its own button

    def apply(self, context: bpy.types.Context, how: str) -> set[str]:
        settings = context.scene.occlux
        obj = scenes.volume_object(context)
        try:
            if obj is None:
                raise ValueError("Apply Classification needs an Occlux volume: Load Volume first")
            scenes.classification_section(settings)  # refused here, before anything runs
            source = Path(bpy.path.abspath(str(obj[SOURCE]))).resolve()
            typed = settings.volume_path
            if typed and Path(bpy.path.abspath(typed)).resolve() != source:
                raise ValueError(
                    f"the active volume '{obj.name}' shows {source.name}, the panel's Volume "
                    f"is {Path(typed).name}: clear Volume or set it to {source.name}"
                )
        except ValueError as e:
            self.report({"ERROR"}, str(e))
            return {"CANCELLED"}
        name = rerun(obj)
        if name == "import_volume" and not typed:  # Load Volume reads the panel's Volume
            settings.volume_path = str(obj[SOURCE])
        try:
            return getattr(bpy.ops.occlux, name)(how)
        except RuntimeError as e:  # the operator's own error report, already shown
            self.report({"ERROR"}, str(e))
            return {"CANCELLED"}


CLASSES = (OCCLUX_OT_suggest_classification, OCCLUX_OT_apply_classification)
