"""Compositing: combine a layer of an Occlux EXR with the render."""

from __future__ import annotations

from pathlib import Path

import bpy
from bpy.props import EnumProperty, FloatProperty, StringProperty

from .. import nodes


class OCCLUX_OT_composite(bpy.types.Operator):
    """Combine a layer of an Occlux EXR with the render in the compositor"""

    bl_idname = "occlux.composite"
    bl_label = "Composite Occlux Layer"
    bl_options = {"REGISTER", "UNDO"}

    filepath: StringProperty(name="EXR", subtype="FILE_PATH")
    layer: StringProperty(name="Layer", default="beauty")
    blend: EnumProperty(
        name="Blend",
        items=[
            (
                "MULTIPLY",
                "Multiply",
                "Shade the render by the layer; an occlusion or shadow layer (V premultiplied "
                "by its coverage A) as render * (1 - strength * (A - V))",
            ),
            ("MIX", "Mix", "Show the layer over the render"),
        ],
        default="MULTIPLY",
    )
    strength: FloatProperty(
        name="Strength",
        description="How much of an occlusion or shadow layer's darkening to apply",
        default=1.0,
        min=0.0,
        max=1.0,
    )

    def execute(self, context: bpy.types.Context) -> set[str]:
        path = Path(bpy.path.abspath(self.filepath))
        if not path.is_file():
            self.report({"ERROR"}, f"no EXR file at '{path}'")
            return {"CANCELLED"}
        if self.layer in nodes.FACTOR_LAYERS and self.blend != "MULTIPLY":
            self.report(
                {"ERROR"},
                f"the '{self.layer}' layer shades the render (Multiply); Mix shows an image "
                "layer such as 'beauty'",
            )
            return {"CANCELLED"}
        image = bpy.data.images.load(str(path), check_existing=True)
        try:
            if self.layer in nodes.FACTOR_LAYERS:
                nodes.shade_group(context.scene, image, self.layer, self.strength)
            else:
                nodes.compositor_group(context.scene, image, self.layer, self.blend)
        except ValueError as e:
            self.report({"ERROR"}, str(e))
            return {"CANCELLED"}
        context.scene.render.use_compositing = True
        return {"FINISHED"}


CLASSES = (OCCLUX_OT_composite,)
