"""Compositing: combine a layer of an Occlux EXR with the render. IPSVI's `shadow` layer is
refused onto a render that already holds the lamps' shadows (`shadows_in_render`): it would
darken the render by them a second time."""

from __future__ import annotations

from pathlib import Path

import bpy
from bpy.props import EnumProperty, FloatProperty, StringProperty

from .. import nodes
from .bake import BAKED, BAKED_TYPES

# The layer of the lamps' shadows (IPSVI's), which a render with shadows already holds.
SHADOW = "shadow"


def shadows_in_render(scene: bpy.types.Scene) -> list[str]:
    """What already darkens the scene's render by the lamps' shadows, which the SHADOW layer
    would apply a second time: each visible sun or point lamp (what IPSVI lights by) that casts
    shadows in the scene's engine (Cycles traces a lamp's volume shadows unless its Cast Shadow
    is off; EEVEE with Volume Shadows on too), and each baked volume (the bake holds its lamps'
    shadows)."""
    engine = scene.render.engine
    traced = engine == "CYCLES" or (
        engine == "BLENDER_EEVEE" and scene.eevee.use_volumetric_shadows
    )
    found = [
        f"lamp '{o.name}'"
        for o in scene.objects
        if traced
        and o.type == "LIGHT"
        and not o.hide_render
        and o.data.type in BAKED_TYPES
        and o.data.use_shadow
    ]
    found += [f"baked volume '{o.name}'" for o in scene.objects if BAKED in o]
    return found


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
        doubled = shadows_in_render(context.scene) if self.layer == SHADOW else []
        if doubled:
            self.report(
                {"ERROR"},
                f"the render already holds the shadows of {', '.join(doubled)}: the "
                f"'{SHADOW}' layer would apply them twice. Composite '{SHADOW}' onto a render "
                "without them (the lamps' Cast Shadow off, or EEVEE without Volume Shadows), "
                "or show IPSVI's own shadowed 'beauty' layer (Mix)",
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
