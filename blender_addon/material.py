"""The Volume object's material and the world it needs: the transfer function on the `value`
grid as Occlux classifies it (the mapping `occlux.blender` renders with Cycles,
docs/cycles-mapping.md: the trilinear value through the control points, extinction per scene
unit), and the `ao` grid wired in.

AO shadings:
- ``AMBIENT`` (the ambient light, baked): the material emits the world's light that the `ao`
  grid lets reach each point, sigma_t * albedo * L_world * mix(1, ao, strength), and the world
  lights only camera rays (it stays the background; `camera_only_world`), so Cycles renders
  what Occlux's AO-shaded render computes (`method = "ao"`, no direct light) while suns and
  lamps still scatter with Cycles' own shadows. With the `sweep-physical` grid (the mean
  transmittance over all directions) this is the single-scattered sky light itself.
- ``ALBEDO``: the albedo darkened by mix(1, ao, strength), lit by Cycles as it is: the world's
  light is occluded twice (by Cycles and by the grid), a stylised look that deepens crevices.

Plain data API (no operators), so it works headless."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import bpy
from occlux.blender.material import box_mask, color_ramp

AO_SHADINGS = ("AMBIENT", "ALBEDO")
# The panel's AO shading that turns the `ao` grid off: the plain material, the world lighting
# every ray (AO strength 0 under AMBIENT is not that: the material still emits the world's
# light, unoccluded, while the world lights camera rays only).
AO_OFF = "OFF"
AO_FACTOR = "Occlux AO factor"
AMBIENT = "Occlux ambient light"
# The baked material's colour nodes of the world's light and of each baked lamp's, driven by
# the world's and the lamp's own settings.
BAKED_WORLD = "Occlux baked world light"
BAKED_LAMP = "Occlux baked light {}"
# The world's Mix Shader that keeps its light from everything but camera rays.
CAMERA_ONLY = "Occlux world for camera rays only"

# (value, sigma_t, albedo RGB, emission RGB): `occlux.Classification.raw_points`, density
# scale applied.
Point = tuple[float, float, Sequence[float], Sequence[float]]
Rgb = tuple[float, float, float]


def _math(tree: bpy.types.NodeTree, operation: str, a, b):
    """`a operation b` for float sockets or values."""
    node = tree.nodes.new("ShaderNodeMath")
    node.operation = operation
    for socket, x in zip(node.inputs, (a, b), strict=False):
        if isinstance(x, float | int):
            socket.default_value = float(x)
        else:
            tree.links.new(x, socket)
    return node.outputs["Value"]


def _colour(tree: bpy.types.NodeTree, blend: str, a, b):
    """`a blend b` for colour sockets (MULTIPLY, ADD), factor 1; a float `b` is a grey."""
    node = tree.nodes.new("ShaderNodeMix")
    node.data_type = "RGBA"
    node.blend_type = blend
    node.inputs["Factor"].default_value = 1.0
    tree.links.new(a, node.inputs[6])  # A (colour)
    tree.links.new(b, node.inputs[7])  # B (colour)
    return node.outputs[2]  # Result (colour)


def _classified(tree: bpy.types.NodeTree, points: Sequence[Point]):
    """The `value` grid through the control points: sockets sigma_t, albedo and the emission
    (None without any)."""
    value = tree.nodes.new("ShaderNodeAttribute")
    value.attribute_type = "GEOMETRY"
    value.attribute_name = "value"
    to_unit = tree.nodes.new("ShaderNodeMapRange")
    to_unit.clamp = True  # the transfer function is constant beyond its end points
    lo, hi = points[0][0], points[-1][0]
    to_unit.inputs["From Min"].default_value = lo
    to_unit.inputs["From Max"].default_value = hi if hi > lo else lo + 1.0
    tree.links.new(value.outputs["Fac"], to_unit.inputs["Value"])
    positions = [(p[0] - lo) / (hi - lo) if hi > lo else 0.0 for p in points]
    # Albedo in RGB, sigma_t / max in alpha: one ramp, one table.
    top = max(p[1] for p in points) or 1.0
    optics_stops = [(*p[2], p[1] / top) for p in points]
    optics = color_ramp(tree, list(zip(positions, optics_stops, strict=True)))
    tree.links.new(to_unit.outputs["Result"], optics.inputs["Fac"])
    sigma_t = _math(tree, "MULTIPLY", optics.outputs["Alpha"], top)
    brightest = max(max(p[3]) for p in points)
    if brightest <= 0.0:
        return sigma_t, optics.outputs["Color"], None
    glow = [(*(e / brightest for e in p[3]), 1.0) for p in points]
    ramp = color_ramp(tree, list(zip(positions, glow, strict=True)))
    tree.links.new(to_unit.outputs["Result"], ramp.inputs["Fac"])
    emitted = _colour(tree, "MULTIPLY", ramp.outputs["Color"], _grey(tree, brightest))
    return sigma_t, optics.outputs["Color"], emitted


def volume_material(
    name: str,
    points: Sequence[Point] | None,
    ao: str | None,
    ao_factor: float,
    world: bpy.types.World | None,
    box: tuple[Rgb, Rgb],
) -> bpy.types.Material:
    """A Principled Volume with Occlux's classification of the `value` grid: Density = sigma_t,
    Color = albedo, the transfer function's emission, Absorption Color black (for a 2D transfer
    function, `points` None: the classified `density` grid and a grey albedo), all within the
    volume's `box` (its cells' bounds in the object's space: Occlux's VDBs are padded by one
    voxel repeating the border, so Cycles' samples inside the box are Occlux's, and the medium
    ends at the box's faces as in Occlux); with an `ao`
    grid, shaded by `ao` (`AO_SHADINGS`, see the module) with the strength in the value node
    AO_FACTOR (the panel's AO strength) and the radiance of `world` in the colour node AMBIENT
    (for AMBIENT shading), driven by the world's own settings: read when the material renders,
    so a world changed after Compute AO lights it as it is."""
    if ao is not None and ao not in AO_SHADINGS:
        raise ValueError(f"ao shading '{ao}': expected one of {', '.join(AO_SHADINGS)}")
    material, tree, shader = _principled(name)
    sigma_t, albedo, emitted = _medium(tree, points, box)
    tree.links.new(sigma_t, shader.inputs["Density"])

    if ao is not None:
        grid = tree.nodes.new("ShaderNodeAttribute")
        grid.attribute_type = "GEOMETRY"
        grid.attribute_name = "ao"
        factor = tree.nodes.new("ShaderNodeValue")
        factor.name = factor.label = AO_FACTOR
        factor.outputs[0].default_value = ao_factor
        shade = tree.nodes.new("ShaderNodeMix")  # mix(1, ao, factor)
        shade.data_type = "FLOAT"
        shade.inputs["A"].default_value = 1.0
        tree.links.new(factor.outputs[0], shade.inputs["Factor"])
        tree.links.new(grid.outputs["Fac"], shade.inputs["B"])
        openness = shade.outputs["Result"]
        if ao == "AMBIENT":
            light = _world_light(tree, world, AMBIENT)
            # sigma_t * albedo * L_world * openness: the ambient light each point scatters
            # towards the camera, seen by camera rays only (a ray cast after a scattering
            # would collect it again: Cycles scatters once even at 0 volume bounces, and
            # measured +65 % on the CT phantom without this).
            seen = tree.nodes.new("ShaderNodeLightPath").outputs["Is Camera Ray"]
            weight = _math(tree, "MULTIPLY", _math(tree, "MULTIPLY", sigma_t, openness), seen)
            scattered = _colour(tree, "MULTIPLY", albedo, light)
            scattered = _colour(tree, "MULTIPLY", scattered, _as_colour(tree, weight))
            emitted = scattered if emitted is None else _colour(tree, "ADD", emitted, scattered)
        else:
            albedo = _colour(tree, "MULTIPLY", albedo, _as_colour(tree, openness))
    tree.links.new(albedo, shader.inputs["Color"])
    if emitted is None:
        shader.inputs["Emission Strength"].default_value = 0.0
    else:
        tree.links.new(emitted, shader.inputs["Emission Color"])
    return material


def ao_shading(choice: str) -> str | None:
    """The material's AO shading for the panel's choice: one of AO_SHADINGS, None for AO_OFF."""
    return None if choice == AO_OFF else choice


@dataclass(frozen=True)
class BakedLamp:
    """A lamp a bake holds (`occlux.bake`): its object's name, its light type (SUN or POINT),
    its grid of the light reaching each voxel per unit strength and, when baked, its grids of
    multiply scattered light per unit strength (red, green, blue)."""

    name: str
    kind: str
    grid: str
    multiple: tuple[str, str, str] | None


# A point lamp of power P watts has radiant intensity P / (4 pi) per unit colour (scenes.lamp),
# and a baked lamp's single scattering is strength x `grid` / (4 pi) for an isotropic phase.
INV_4PI = 0.25 / math.pi


def baked_material(
    name: str,
    points: Sequence[Point] | None,
    box: tuple[Rgb, Rgb],
    world: bpy.types.World | None,
    lamps: Sequence[BakedLamp],
    world_multiple: Sequence[str] | None = None,
) -> bpy.types.Material:
    """The material of a baked volume (Bake Light): Occlux's classification as in
    `volume_material`, a pure absorber (no scattering colour: Cycles and EEVEE trace no light in
    it) that emits the baked light, sigma_t * albedo * (L_world * (ao + world_multiple) + sum
    over the lamps of strength * colour * (grid / 4 pi + multiple)), plus the transfer
    function's emission (`world_multiple`: the red, green and blue grids of the world's multiply
    scattered light, if baked). The
    world's radiance (colour node BAKED_WORLD) and each lamp's strength and colour (BAKED_LAMP)
    are driven by the world's Background node and the lamp's data, so they are read whenever
    the material renders; changing them needs no new bake."""
    material, tree, shader = _principled(name)
    sigma_t, albedo, emitted = _medium(tree, points, box)
    tree.links.new(sigma_t, shader.inputs["Density"])
    shader.inputs["Color"].default_value = (0.0, 0.0, 0.0, 1.0)
    visible = _plus_multiple(tree, _as_colour(tree, _grid(tree, "ao")), world_multiple)
    light = _colour(tree, "MULTIPLY", _world_light(tree, world, BAKED_WORLD), visible)
    for lamp in lamps:
        light = _colour(tree, "ADD", light, _lamp_light(tree, lamp))
    scattered = _colour(tree, "MULTIPLY", albedo, light)
    scattered = _colour(tree, "MULTIPLY", scattered, _as_colour(tree, sigma_t))
    emitted = scattered if emitted is None else _colour(tree, "ADD", emitted, scattered)
    tree.links.new(emitted, shader.inputs["Emission Color"])
    return material


def _grid(tree: bpy.types.NodeTree, name: str):
    """The float socket of grid `name`."""
    node = tree.nodes.new("ShaderNodeAttribute")
    node.attribute_type = "GEOMETRY"
    node.attribute_name = name
    return node.outputs["Fac"]


def _driven_colour(tree: bpy.types.NodeTree, label: str, drive) -> bpy.types.NodeSocket:
    """A colour node `label` whose three channels `drive(socket, channel)` drives."""
    node = tree.nodes.new("ShaderNodeRGB")
    node.name = node.label = label
    node.outputs[0].default_value = (0.0, 0.0, 0.0, 1.0)
    for channel in range(3):
        drive(node.outputs[0], channel)
    return node.outputs[0]


def _driver(socket, channel: int, expression: str, targets: Sequence[tuple]) -> None:
    """Drives `channel` of `socket`'s value by `expression` of the (variable, id type, id, data
    path) `targets`. Expressions of products of variables and numbers are Blender's simple
    expressions: they run without Python, with auto-run scripts off."""
    driver = socket.driver_add("default_value", channel).driver
    driver.type = "SCRIPTED"
    for variable, id_type, owner, path in targets:
        var = driver.variables.new()
        var.name, var.type = variable, "SINGLE_PROP"
        var.targets[0].id_type = id_type
        var.targets[0].id = owner
        var.targets[0].data_path = path
    driver.expression = expression


def world_shader(world: bpy.types.World) -> bpy.types.Node | None:
    """The node whose shader lights the world (behind a CAMERA_ONLY mix, which keeps an AO
    material's world from all but camera rays: still the scene's ambient light), None for a
    world without nodes or output."""
    tree = world.node_tree
    output = tree and next((n for n in tree.nodes if n.bl_idname == "ShaderNodeOutputWorld"), None)
    if output is None or not output.inputs["Surface"].links:
        return None
    node = output.inputs["Surface"].links[0].from_node
    if node.name == CAMERA_ONLY and node.inputs[2].links:
        node = node.inputs[2].links[0].from_node
    return node


def _world_light(tree: bpy.types.NodeTree, world: bpy.types.World | None, label: str):
    """The world's radiance in a colour node `label`, driven by its Background node's colour
    and strength (or its colour, without nodes; `scenes.world_radiance` has refused any other
    world); black without a world."""
    if world is None:
        black = _grey(tree, 0.0)
        black.node.name = black.node.label = label
        return black
    background = world_shader(world)

    def drive(socket, channel: int) -> None:
        if background is None:
            _driver(socket, channel, "c", [("c", "WORLD", world, f"color[{channel}]")])
            return
        node = f'node_tree.nodes["{background.name}"]'
        _driver(
            socket,
            channel,
            "c * s",
            [
                ("c", "WORLD", world, f"{node}.inputs[0].default_value[{channel}]"),
                ("s", "WORLD", world, f"{node}.inputs[1].default_value"),
            ],
        )

    return _driven_colour(tree, label, drive)


def _lamp_light(tree: bpy.types.NodeTree, lamp: BakedLamp):
    """A baked lamp's light at each point: strength x colour (driven by the lamp's data) times
    its single scattering per unit strength (`grid` / 4 pi) plus its multiple scattering."""
    data = bpy.data.objects[lamp.name].data
    # A sun's strength is its irradiance; a point lamp's power P has intensity P / (4 pi).
    per_unit = "" if lamp.kind == "SUN" else f" * {INV_4PI!r}"

    def drive(socket, channel: int) -> None:
        targets = [
            ("c", "LIGHT", data, f"color[{channel}]"),
            ("e", "LIGHT", data, "energy"),
        ]
        _driver(socket, channel, f"c * e{per_unit}", targets)

    strength = _driven_colour(tree, BAKED_LAMP.format(lamp.name), drive)
    once = _as_colour(tree, _math(tree, "MULTIPLY", _grid(tree, lamp.grid), INV_4PI))
    return _colour(tree, "MULTIPLY", strength, _plus_multiple(tree, once, lamp.multiple))


def _plus_multiple(tree: bpy.types.NodeTree, once, multiple: Sequence[str] | None):
    """The colour socket `once` plus the colour of the red, green and blue grids `multiple`
    (a light's multiply scattered light), if baked."""
    if multiple is None:
        return once
    channels = tree.nodes.new("ShaderNodeCombineColor")
    for socket, grid in zip(channels.inputs[:3], multiple, strict=True):
        tree.links.new(_grid(tree, grid), socket)
    return _colour(tree, "ADD", once, channels.outputs["Color"])


def _principled(name: str):
    """A new material `name` whose Principled Volume (no grids of its own, black absorption
    colour, no blackbody, emission strength 1) feeds the Volume output: (material, tree,
    shader)."""
    material = bpy.data.materials.new(name)
    material.cycles.volume_interpolation = "LINEAR"  # trilinear, as Occlux samples
    tree = material.node_tree
    tree.nodes.clear()
    shader = tree.nodes.new("ShaderNodeVolumePrincipled")
    # Density and colour come from the `value` grid through the points: a grid named `density`
    # would otherwise multiply the density, and `color` the colour.
    shader.inputs["Density Attribute"].default_value = ""
    shader.inputs["Color Attribute"].default_value = ""
    shader.inputs["Absorption Color"].default_value = (0.0, 0.0, 0.0, 1.0)
    shader.inputs["Blackbody Intensity"].default_value = 0.0
    shader.inputs["Emission Strength"].default_value = 1.0
    output = tree.nodes.new("ShaderNodeOutputMaterial")
    tree.links.new(shader.outputs["Volume"], output.inputs["Volume"])
    return material, tree, shader


def _medium(tree: bpy.types.NodeTree, points: Sequence[Point] | None, box: tuple[Rgb, Rgb]):
    """Occlux's classification within the volume's `box`: sockets sigma_t, albedo and the
    transfer function's emission (None without any); for a 2D transfer function (`points`
    None) the classified `density` grid and a grey albedo."""
    emitted = None
    if points is None:
        density = tree.nodes.new("ShaderNodeAttribute")
        density.attribute_type = "GEOMETRY"
        density.attribute_name = "density"
        sigma_t = density.outputs["Fac"]
        albedo = _grey(tree, 0.8)
    else:
        sigma_t, albedo, emitted = _classified(tree, points)
    inside = box_mask(tree, box)
    sigma_t = _math(tree, "MULTIPLY", sigma_t, inside)
    if emitted is not None:
        emitted = _colour(tree, "MULTIPLY", emitted, _as_colour(tree, inside))
    return sigma_t, albedo, emitted


def _grey(tree: bpy.types.NodeTree, value: float):
    node = tree.nodes.new("ShaderNodeRGB")
    node.outputs[0].default_value = (value, value, value, 1.0)
    return node.outputs[0]


def _as_colour(tree: bpy.types.NodeTree, value):
    """A float socket as a grey colour."""
    node = tree.nodes.new("ShaderNodeCombineColor")
    for channel in node.inputs[:3]:
        tree.links.new(value, channel)
    return node.outputs["Color"]


def camera_only_world(scene: bpy.types.Scene) -> None:
    """Keeps the scene's world's light from everything but camera rays (`camera_only`); a
    scene without a world gets one."""
    world = scene.world or bpy.data.worlds.new("World")
    scene.world = world
    camera_only(world)


def camera_only(world: bpy.types.World) -> None:
    """Keeps the world's light from everything but camera rays (it stays the background): a
    Light Path's Is Camera Ray mixes the world's shader with black before the World Output, in
    a Mix Shader named CAMERA_ONLY. Done once; a world without nodes gets a Background node of
    its colour first."""
    tree = world.node_tree
    if tree is None:
        world.use_nodes = True
        tree = world.node_tree
    if CAMERA_ONLY in tree.nodes:
        mix = tree.nodes[CAMERA_ONLY]
        if not mix.inputs["Fac"].links:  # lit by `all_rays`: gated again
            path = tree.nodes.new("ShaderNodeLightPath")
            tree.links.new(path.outputs["Is Camera Ray"], mix.inputs["Fac"])
        return
    output = next((n for n in tree.nodes if n.bl_idname == "ShaderNodeOutputWorld"), None)
    if output is None:
        output = tree.nodes.new("ShaderNodeOutputWorld")
    links = output.inputs["Surface"].links
    if links:
        source = links[0].from_socket
    else:
        background = tree.nodes.new("ShaderNodeBackground")
        background.inputs["Color"].default_value = (*world.color, 1.0)
        source = background.outputs["Background"]
    path = tree.nodes.new("ShaderNodeLightPath")
    mix = tree.nodes.new("ShaderNodeMixShader")  # shader 1 (factor 0) unconnected: black
    mix.name = mix.label = CAMERA_ONLY
    tree.links.new(path.outputs["Is Camera Ray"], mix.inputs["Fac"])
    tree.links.new(source, mix.inputs[2])
    tree.links.new(mix.outputs["Shader"], output.inputs["Surface"])


def all_rays(world: bpy.types.World) -> None:
    """Undoes `camera_only`: the world lights every ray again (its CAMERA_ONLY mix passes the
    world's shader whatever the ray)."""
    tree = world.node_tree
    if tree is None or CAMERA_ONLY not in tree.nodes:
        return
    mix = tree.nodes[CAMERA_ONLY]
    for link in list(mix.inputs["Fac"].links):
        tree.links.remove(link)
    mix.inputs["Fac"].default_value = 1.0


def carries_ambient(shading: bpy.types.Material | None) -> bool:
    """Whether a material emits the world's light, as AMBIENT shading and a bake do (then the
    world must light only camera rays)."""
    tree = None if shading is None else shading.node_tree
    return tree is not None and (AMBIENT in tree.nodes or BAKED_WORLD in tree.nodes)


def without_ao(shading: bpy.types.Material, g: float) -> None:
    """Turns the `ao` grid's shading off in a material `volume_material` made (the openness
    counts fully unoccluded and the AMBIENT emission is black, while the transfer function's
    own emission stays) and gives its volume shaders the phase asymmetry `g`, where the user has
    not wired one: the material of the path-traced truth of an AO figure."""
    if shading.node_tree is None:
        return
    nodes = shading.node_tree.nodes
    if AO_FACTOR in nodes:
        nodes[AO_FACTOR].outputs[0].default_value = 0.0
    if AMBIENT in nodes:
        # Its drivers would bring the world's light back.
        animation = shading.node_tree.animation_data
        for fcurve in list(animation.drivers) if animation else []:
            if fcurve.data_path.startswith(f'nodes["{AMBIENT}"]'):
                animation.drivers.remove(fcurve)
        nodes[AMBIENT].outputs[0].default_value = (0.0, 0.0, 0.0, 1.0)
    for node in nodes:
        anisotropy = node.inputs.get("Anisotropy")
        if node.bl_idname.startswith("ShaderNodeVolume") and anisotropy and not anisotropy.links:
            anisotropy.default_value = g
