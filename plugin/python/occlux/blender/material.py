"""The shader node trees of the Cycles mapping: the transfer function as a Principled Volume on
the ``value`` grid (masked to the volume's box), and the world of an estimator (one radiance for
camera rays, another for every other ray)."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from .common import Rgb
from .scene import TfPoint

PREFIX = "occlux-cycles"
"""Names of the Blender data the harness creates (and removes before building again)."""


def _triple(a: np.ndarray) -> Rgb:
    return (float(a[0]), float(a[1]), float(a[2]))


def _link(tree, socket_out, socket_in) -> None:
    tree.links.new(socket_out, socket_in)


def _socket(sockets, identifier: str):
    """A node socket by identifier (the Mix node's sockets share names across data types)."""
    return next(s for s in sockets if s.identifier == identifier)


def color_ramp(tree, stops: Sequence[tuple[float, Sequence[float]]]):
    """A Color Ramp node with LINEAR interpolation through (position, RGBA) stops, positions
    ascending (the add-on's volume material builds its ramps with it too)."""
    node = tree.nodes.new("ShaderNodeValToRGB")
    fill_ramp(node.color_ramp, stops)
    return node


def fill_ramp(ramp, stops: Sequence[tuple[float, Sequence[float]]]) -> None:
    """Makes a Color Ramp's elements the (position, RGBA) stops, positions ascending, with
    LINEAR interpolation in RGB (the add-on's editable transfer function starts so too)."""
    ramp.interpolation = "LINEAR"
    ramp.color_mode = "RGB"
    while len(ramp.elements) > 1:
        ramp.elements.remove(ramp.elements[-1])
    ramp.elements[0].position = stops[0][0]
    for position, _ in stops[1:]:
        ramp.elements.new(position)
    # Elements are kept sorted by position, as the stops are.
    for element, (_, rgba) in zip(ramp.elements, stops, strict=True):
        element.color = rgba


def _ramp_positions(points: Sequence[TfPoint]) -> list[float]:
    """Stop positions: the raw values mapped linearly from [first, last] onto [0, 1]."""
    lo, hi = points[0].value, points[-1].value
    if hi <= lo:
        return [0.0] * len(points)
    return [(p.value - lo) / (hi - lo) for p in points]


def box_mask(tree, box: tuple[Rgb, Rgb]):
    """A shader value that is 1 inside the axis-aligned ``box`` of the volume object's own
    space (where its grids' transforms place the voxels, wherever the object is moved) and 0
    outside: Occlux's medium ends at the box's faces, where Cycles would fade a padded grid
    over one more voxel (the add-on's volume material uses it too)."""
    lo, hi = np.asarray(box[0]), np.asarray(box[1])
    position = tree.nodes.new("ShaderNodeTexCoord")
    offset = tree.nodes.new("ShaderNodeVectorMath")
    offset.operation = "SUBTRACT"
    offset.inputs[1].default_value = _triple(0.5 * (lo + hi))
    _link(tree, position.outputs["Object"], offset.inputs[0])
    scaled = tree.nodes.new("ShaderNodeVectorMath")
    scaled.operation = "DIVIDE"
    scaled.inputs[1].default_value = _triple(0.5 * (hi - lo))
    _link(tree, offset.outputs["Vector"], scaled.inputs[0])
    # The box is where the largest |coordinate| of the scaled offset is below 1.
    extent = tree.nodes.new("ShaderNodeVectorMath")
    extent.operation = "ABSOLUTE"
    _link(tree, scaled.outputs["Vector"], extent.inputs[0])
    xyz = tree.nodes.new("ShaderNodeSeparateXYZ")
    _link(tree, extent.outputs["Vector"], xyz.inputs[0])
    largest = xyz.outputs["X"]
    for axis in "YZ":
        node = tree.nodes.new("ShaderNodeMath")
        node.operation = "MAXIMUM"
        _link(tree, largest, node.inputs[0])
        _link(tree, xyz.outputs[axis], node.inputs[1])
        largest = node.outputs["Value"]
    inside = tree.nodes.new("ShaderNodeMath")
    inside.operation = "LESS_THAN"
    inside.inputs[1].default_value = 1.0
    _link(tree, largest, inside.inputs[0])
    return inside.outputs["Value"]


def _emission_seen(tree, bounces: int):
    """1 on rays that have scattered at most ``bounces`` times, else 0.

    Occlux's estimators count the emission of the camera segment and of the segments after
    the first ``bounces`` scatterings; a Cycles path that may scatter ``bounces`` more times
    (volume bounces) also collects emission along the ray it casts after its last scattering
    (measured: with 0 bounces, albedo 0.9 and no lights, Cycles adds +26 % to the emission
    image of the phantom; with albedo 0 the two agree)."""
    path = tree.nodes.new("ShaderNodeLightPath")
    seen = tree.nodes.new("ShaderNodeMath")
    seen.operation = "LESS_THAN"
    seen.inputs[1].default_value = bounces + 0.5
    _link(tree, path.outputs["Ray Depth"], seen.inputs[0])
    return seen.outputs["Value"]


def make_material(bpy, points: Sequence[TfPoint], box: tuple[Rgb, Rgb], g: float, bounces: int):
    """The transfer function on the ``value`` grid, into a Principled Volume: Density = sigma_t
    inside ``box`` and 0 outside, Color = albedo, Absorption Color black, Anisotropy = g,
    emission per unit length on the rays Occlux counts it on (see :func:`_emission_seen`)."""
    mat = bpy.data.materials.new(f"{PREFIX}-material")
    mat.cycles.volume_interpolation = "LINEAR"  # trilinear, as Occlux samples
    tree = mat.node_tree
    tree.nodes.clear()
    value = tree.nodes.new("ShaderNodeAttribute")
    value.attribute_type = "GEOMETRY"
    value.attribute_name = "value"
    to_unit = tree.nodes.new("ShaderNodeMapRange")
    to_unit.clamp = True  # the transfer function is constant beyond its end points
    to_unit.inputs["From Min"].default_value = points[0].value
    to_unit.inputs["From Max"].default_value = points[-1].value
    _link(tree, value.outputs["Fac"], to_unit.inputs["Value"])
    positions = _ramp_positions(points)
    # Albedo in RGB, sigma_t / max in alpha: one ramp, one table.
    max_sigma = max(p.sigma_t for p in points)
    optics = color_ramp(
        tree,
        [(t, (*p.albedo, p.sigma_t / max_sigma)) for t, p in zip(positions, points, strict=True)],
    )
    _link(tree, to_unit.outputs["Result"], optics.inputs["Fac"])
    scale = tree.nodes.new("ShaderNodeMath")
    scale.operation = "MULTIPLY"
    scale.inputs[1].default_value = max_sigma
    _link(tree, optics.outputs["Alpha"], scale.inputs[0])
    inside = box_mask(tree, box)
    density = tree.nodes.new("ShaderNodeMath")
    density.operation = "MULTIPLY"
    _link(tree, scale.outputs["Value"], density.inputs[0])
    _link(tree, inside, density.inputs[1])
    volume = tree.nodes.new("ShaderNodeVolumePrincipled")
    _link(tree, density.outputs["Value"], volume.inputs["Density"])
    _link(tree, optics.outputs["Color"], volume.inputs["Color"])
    # A grid named `density` (as `occlux export` writes) would otherwise multiply the density
    # (measured: the engine's transmittance fell from 0.08 to 0.007), and `color` the colour.
    volume.inputs["Density Attribute"].default_value = ""
    volume.inputs["Color Attribute"].default_value = ""
    volume.inputs["Absorption Color"].default_value = (0.0, 0.0, 0.0, 1.0)
    volume.inputs["Anisotropy"].default_value = g
    volume.inputs["Blackbody Intensity"].default_value = 0.0
    max_emission = max(max(p.emission) for p in points)
    if max_emission > 0.0:
        emission = color_ramp(
            tree,
            [
                (t, (*(e / max_emission for e in p.emission), 1.0))
                for t, p in zip(positions, points, strict=True)
            ],
        )
        _link(tree, to_unit.outputs["Result"], emission.inputs["Fac"])
        _link(tree, emission.outputs["Color"], volume.inputs["Emission Color"])
        strength = tree.nodes.new("ShaderNodeMath")
        strength.operation = "MULTIPLY"
        strength.inputs[1].default_value = max_emission
        _link(tree, _emission_seen(tree, bounces), strength.inputs[0])
        # No medium beyond the box emits either.
        masked = tree.nodes.new("ShaderNodeMath")
        masked.operation = "MULTIPLY"
        _link(tree, strength.outputs["Value"], masked.inputs[0])
        _link(tree, inside, masked.inputs[1])
        _link(tree, masked.outputs["Value"], volume.inputs["Emission Strength"])
    else:
        volume.inputs["Emission Strength"].default_value = 0.0
    output = tree.nodes.new("ShaderNodeOutputMaterial")
    output.target = "CYCLES"
    _link(tree, volume.outputs["Volume"], output.inputs["Volume"])
    return mat


def colour_and_strength(rgb: Rgb) -> tuple[tuple[float, float, float, float], float]:
    """An RGB quantity as a colour in [0, 1] and a strength."""
    peak = max(rgb)
    if peak <= 0.0:
        return (0.0, 0.0, 0.0, 1.0), 0.0
    return (*(c / peak for c in rgb), 1.0), peak


def make_world(bpy, environment: Rgb, background: Rgb):
    """Radiance ``background`` for camera rays, ``environment`` for every other ray."""
    world = bpy.data.worlds.new(f"{PREFIX}-world")
    tree = world.node_tree
    tree.nodes.clear()
    peak = max(*environment, *background)
    strength = peak if peak > 0.0 else 0.0
    norm = peak if peak > 0.0 else 1.0
    path = tree.nodes.new("ShaderNodeLightPath")
    mix = tree.nodes.new("ShaderNodeMix")
    mix.data_type = "RGBA"
    mix.blend_type = "MIX"
    _socket(mix.inputs, "A_Color").default_value = (*(c / norm for c in environment), 1.0)
    _socket(mix.inputs, "B_Color").default_value = (*(c / norm for c in background), 1.0)
    _link(tree, path.outputs["Is Camera Ray"], _socket(mix.inputs, "Factor_Float"))
    shader = tree.nodes.new("ShaderNodeBackground")
    shader.inputs["Strength"].default_value = strength
    _link(tree, _socket(mix.outputs, "Result_Color"), shader.inputs["Color"])
    output = tree.nodes.new("ShaderNodeOutputWorld")
    _link(tree, shader.outputs["Background"], output.inputs["Surface"])
    return world
