"""Compositing: combine a layer of an Occlux EXR with the render."""

from __future__ import annotations

from pathlib import Path

import bpy
from bpy.props import EnumProperty, FloatProperty, StringProperty

from .. import nodes

# Occlux's compositing layers (render::Factor in the core): channels V, the method's factor
# premultiplied by coverage (P), and A, the coverage. Blender reads such a two-channel layer
# as a vector socket with the channels in the file's (sorted) order: X = A, Y = V.
FACTOR_LAYERS = ("occlusion", "shadow")


def shade_group(
    scene: bpy.types.Scene, exr: bpy.types.Image, layer: str, strength: float
) -> bpy.types.NodeTree:
    """The scene's compositor: the Cycles render layer shaded by Occlux's factor layer `layer`
    (P = `layer.V`, A = `layer.A`): ``render * (1 - strength * (A - P))``, a multiplier that is 1
    where the layer has no coverage (A = 0) and darkens by the occluded share of what is seen
    elsewhere. The strength is the value node named "Occlux strength"."""
    tree = bpy.data.node_groups.new("Occlux compositing", "CompositorNodeTree")
    tree.interface.new_socket("Image", in_out="OUTPUT", socket_type="NodeSocketColor")
    render = tree.nodes.new("CompositorNodeRLayers")
    render.scene = scene
    image = tree.nodes.new("CompositorNodeImage")
    image.image = exr
    if layer not in image.outputs:
        known = ", ".join(o.name for o in image.outputs if o.enabled)
        bpy.data.node_groups.remove(tree)  # the node is gone with it: read it before
        raise ValueError(f"{exr.filepath} has no layer '{layer}' (it has {known})")
    channels = tree.nodes.new("ShaderNodeSeparateXYZ")  # X = A (coverage), Y = V (P)
    tree.links.new(image.outputs[layer], channels.inputs[0])
    occluded = tree.nodes.new("ShaderNodeMath")  # A - P
    occluded.operation = "SUBTRACT"
    tree.links.new(channels.outputs["X"], occluded.inputs[0])
    tree.links.new(channels.outputs["Y"], occluded.inputs[1])
    weight = tree.nodes.new("ShaderNodeValue")
    weight.name = weight.label = "Occlux strength"
    weight.outputs[0].default_value = strength
    scaled = tree.nodes.new("ShaderNodeMath")  # strength * (A - P)
    scaled.operation = "MULTIPLY"
    tree.links.new(occluded.outputs[0], scaled.inputs[0])
    tree.links.new(weight.outputs[0], scaled.inputs[1])
    factor = tree.nodes.new("ShaderNodeMath")  # 1 - strength * (A - P)
    factor.operation = "SUBTRACT"
    factor.inputs[0].default_value = 1.0
    tree.links.new(scaled.outputs[0], factor.inputs[1])
    mix = tree.nodes.new("ShaderNodeMix")  # render * factor
    mix.data_type = "RGBA"
    mix.blend_type = "MULTIPLY"
    mix.inputs["Factor"].default_value = 1.0
    out = tree.nodes.new("NodeGroupOutput")
    tree.links.new(render.outputs["Image"], mix.inputs[6])
    tree.links.new(factor.outputs[0], mix.inputs[7])
    tree.links.new(mix.outputs[2], out.inputs[0])
    scene.compositing_node_group = tree
    return tree


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
        if self.layer in FACTOR_LAYERS and self.blend != "MULTIPLY":
            self.report(
                {"ERROR"},
                f"the '{self.layer}' layer shades the render (Multiply); Mix shows an image "
                "layer such as 'beauty'",
            )
            return {"CANCELLED"}
        image = bpy.data.images.load(str(path), check_existing=True)
        try:
            if self.layer in FACTOR_LAYERS:
                shade_group(context.scene, image, self.layer, self.strength)
            else:
                nodes.compositor_group(context.scene, image, self.layer, self.blend)
        except ValueError as e:
            self.report({"ERROR"}, str(e))
            return {"CANCELLED"}
        context.scene.render.use_compositing = True
        return {"FINISHED"}


CLASSES = (OCCLUX_OT_composite,)
