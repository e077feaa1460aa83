"""Node trees the add-on builds: the volume material and the compositor group. Plain data API
(no operators), so it works headless."""

from __future__ import annotations

from collections.abc import Sequence

import bpy

Point = tuple[float, float, Sequence[float], Sequence[float]]
AO_FACTOR = "Occlux AO factor"
AO_SHADINGS = ("ALBEDO", "EMISSION")


def _ramp(tree: bpy.types.NodeTree, stops: Sequence[tuple[float, Sequence[float]]]):
    """A linear ColorRamp through `stops` (position in [0, 1], RGB)."""
    ramp = tree.nodes.new("ShaderNodeValToRGB")
    ramp.color_ramp.interpolation = "LINEAR"
    elements = ramp.color_ramp.elements
    while len(elements) < len(stops):
        elements.new(0.5)
    for element, (position, rgb) in zip(elements, stops, strict=True):
        element.position = position
        element.color = (*rgb, 1.0)
    return ramp


def volume_material(
    name: str,
    points: Sequence[Point] | None,
    value_range: tuple[float, float],
    units: str,
    ao: str | None,
    ao_factor: float,
) -> bpy.types.Material:
    """A Principled Volume reading the `density` grid (extinction per scene unit, so Density is
    1) and an albedo from the transfer function's colours over the `value` grid. With an `ao`
    grid, read by an Attribute node: ``ao="ALBEDO"`` darkens the albedo by
    ``mix(1, ao, factor)``; ``ao="EMISSION"`` emits the albedo colour with strength
    ``factor * ao``. The factor is the value node named AO_FACTOR (the panel's AO strength).
    The grid is the one ``occlux.ao_volume`` writes by default (``convention="unoccluded"``):
    1 where nothing occludes (empty space, an open flat surface), so ao = 1 leaves the albedo
    and the emission as they are and only crevices and the matter or air hemmed in by denser
    matter darken. A ``convention="raw"`` VAO grid (1/2 in empty space and on flat surfaces)
    would darken everything by half: the add-on never asks for one."""
    material = bpy.data.materials.get(name) or bpy.data.materials.new(name)
    tree = material.node_tree
    if tree is None:  # Blender 5 gives new materials a tree; older ones need use_nodes
        material.use_nodes = True
        tree = material.node_tree
    tree.nodes.clear()
    out = tree.nodes.new("ShaderNodeOutputMaterial")
    shader = tree.nodes.new("ShaderNodeVolumePrincipled")
    shader.inputs["Density"].default_value = 1.0
    shader.inputs["Density Attribute"].default_value = "density"
    shader.inputs["Absorption Color"].default_value = (0.0, 0.0, 0.0, 1.0)
    tree.links.new(shader.outputs["Volume"], out.inputs["Volume"])

    if points and len(points) <= 32:
        value = tree.nodes.new("ShaderNodeAttribute")
        value.attribute_name = "value"
        # The ramp spans the control points; normalized positions are fractions of the
        # volume's value range.
        p0, pn = points[0][0], points[-1][0]
        lo, hi = value_range
        a, b = (p0, pn) if units == "raw" else (lo + p0 * (hi - lo), lo + pn * (hi - lo))
        to_ramp = tree.nodes.new("ShaderNodeMapRange")
        to_ramp.inputs["From Min"].default_value = a
        to_ramp.inputs["From Max"].default_value = b if b > a else a + 1.0
        ramp = _ramp(tree, [((p[0] - p0) / ((pn - p0) or 1.0), p[2]) for p in points])
        tree.links.new(value.outputs["Fac"], to_ramp.inputs["Value"])
        tree.links.new(to_ramp.outputs["Result"], ramp.inputs["Fac"])
        albedo = ramp.outputs["Color"]
    else:  # a 2D transfer function: no 1D ramp to follow
        grey = tree.nodes.new("ShaderNodeRGB")
        grey.outputs[0].default_value = (0.8, 0.8, 0.8, 1.0)
        albedo = grey.outputs[0]

    if ao is not None:
        if ao not in AO_SHADINGS:
            raise ValueError(f"ao shading '{ao}': expected one of {', '.join(AO_SHADINGS)}")
        grid = tree.nodes.new("ShaderNodeAttribute")
        grid.attribute_name = "ao"
        factor = tree.nodes.new("ShaderNodeValue")
        factor.name = factor.label = AO_FACTOR
        factor.outputs[0].default_value = ao_factor
        if ao == "EMISSION":
            strength = tree.nodes.new("ShaderNodeMath")  # factor * ao
            strength.operation = "MULTIPLY"
            tree.links.new(factor.outputs[0], strength.inputs[0])
            tree.links.new(grid.outputs["Fac"], strength.inputs[1])
            tree.links.new(strength.outputs[0], shader.inputs["Emission Strength"])
            tree.links.new(albedo, shader.inputs["Emission Color"])
        else:
            shade = tree.nodes.new("ShaderNodeMix")  # mix(1, ao, factor)
            shade.data_type = "FLOAT"
            shade.inputs["A"].default_value = 1.0
            tree.links.new(factor.outputs[0], shade.inputs["Factor"])
            tree.links.new(grid.outputs["Fac"], shade.inputs["B"])
            darken = tree.nodes.new("ShaderNodeMix")
            darken.data_type = "RGBA"
            darken.blend_type = "MULTIPLY"
            darken.inputs["Factor"].default_value = 1.0
            tree.links.new(albedo, darken.inputs[6])  # A (colour)
            tree.links.new(shade.outputs["Result"], darken.inputs[7])  # B (colour)
            albedo = darken.outputs[2]  # Result (colour)
    tree.links.new(albedo, shader.inputs["Color"])
    return material


def compositor_group(
    scene: bpy.types.Scene, exr: bpy.types.Image, layer: str, blend: str
) -> bpy.types.NodeTree:
    """The scene's compositor: the Cycles render layer combined with Occlux's EXR `layer` by
    `blend` ("MULTIPLY": shade the render by an occlusion layer; "MIX": show Occlux's image)."""
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
