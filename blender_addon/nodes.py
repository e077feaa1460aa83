"""The compositor groups the add-on builds (the volume material is material.py's). Plain data
API (no operators), so it works headless."""

from __future__ import annotations

import bpy

# Occlux's compositing layers (render::Factor in the core): channels V, the method's factor
# premultiplied by coverage (P), and A, the coverage. Blender reads such a two-channel layer
# as a vector socket with the channels in the file's (sorted) order: X = A, Y = V.
FACTOR_LAYERS = ("occlusion", "shadow")


def _layer_tree(scene: bpy.types.Scene, exr: bpy.types.Image, layer: str):
    """A new compositor group with the scene's render layer, the EXR's `layer` and the group
    output: (tree, render socket, layer socket, output node). An EXR without `layer` is an
    error naming the layers it has, and leaves no group behind."""
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
    out = tree.nodes.new("NodeGroupOutput")
    return tree, render.outputs["Image"], image.outputs[layer], out


def _blend(tree: bpy.types.NodeTree, blend: str, a, b):
    """`a blend b` for colours, factor 1."""
    mix = tree.nodes.new("ShaderNodeMix")
    mix.data_type = "RGBA"
    mix.blend_type = blend
    mix.inputs["Factor"].default_value = 1.0
    tree.links.new(a, mix.inputs[6])
    tree.links.new(b, mix.inputs[7])
    return mix.outputs[2]


def compositor_group(
    scene: bpy.types.Scene, exr: bpy.types.Image, layer: str, blend: str
) -> bpy.types.NodeTree:
    """The scene's compositor: the Cycles render layer combined with Occlux's EXR `layer` by
    `blend` ("MULTIPLY": multiply the render by an image layer; "MIX": show it over the
    render). The factor layers (FACTOR_LAYERS) go through `shade_group`."""
    tree, render, image, out = _layer_tree(scene, exr, layer)
    tree.links.new(_blend(tree, blend, render, image), out.inputs[0])
    scene.compositing_node_group = tree
    return tree


def shade_group(
    scene: bpy.types.Scene, exr: bpy.types.Image, layer: str, strength: float
) -> bpy.types.NodeTree:
    """The scene's compositor: the Cycles render layer shaded by Occlux's factor layer `layer`
    (P = `layer.V`, A = `layer.A`): ``render * (1 - strength * (A - P))``, a multiplier that is 1
    where the layer has no coverage (A = 0) and darkens by the occluded share of what is seen
    elsewhere. The strength is the value node named "Occlux strength"."""
    tree, render, image, out = _layer_tree(scene, exr, layer)
    channels = tree.nodes.new("ShaderNodeSeparateXYZ")  # X = A (coverage), Y = V (P)
    tree.links.new(image, channels.inputs[0])
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
    tree.links.new(_blend(tree, "MULTIPLY", render, factor.outputs[0]), out.inputs[0])
    scene.compositing_node_group = tree
    return tree
