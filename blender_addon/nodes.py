"""The compositor group the add-on builds (the volume material is material.py's). Plain data
API (no operators), so it works headless."""

from __future__ import annotations

import bpy


def compositor_group(
    scene: bpy.types.Scene, exr: bpy.types.Image, layer: str, blend: str
) -> bpy.types.NodeTree:
    """The scene's compositor: the Cycles render layer combined with Occlux's EXR `layer` by
    `blend` ("MULTIPLY": multiply the render by an image layer; "MIX": show it over the render).
    The factor layers (`occlusion`, `shadow`) go through `operators.composite.shade_group`."""
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
    mix = tree.nodes.new("ShaderNodeMix")
    mix.data_type = "RGBA"
    mix.blend_type = blend
    mix.inputs["Factor"].default_value = 1.0
    out = tree.nodes.new("NodeGroupOutput")
    tree.links.new(render.outputs["Image"], mix.inputs[6])
    tree.links.new(image.outputs[layer], mix.inputs[7])
    tree.links.new(mix.outputs[2], out.inputs[0])
    scene.compositing_node_group = tree
    return tree
