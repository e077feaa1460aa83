"""The Blender scene as an Occlux scene file (TOML): the volume settings, the active camera and
the lights. Read on the main thread; the text is what the jobs hand to the core and to the
Cycles harness (occlux.cycles), which map it back onto Blender the same way."""

from __future__ import annotations

import json
import math
from collections.abc import Sequence
from pathlib import Path

import bpy


def _list(values: Sequence[float]) -> str:
    return json.dumps([round(float(v), 9) for v in values])


def camera_toml(scene: bpy.types.Scene, width: int, height: int) -> str:
    """The active camera at `width` x `height`. The vertical field of view (or orthographic
    scale) comes from Blender's own projection at that size, so every sensor fit maps."""
    camera = scene.camera
    if camera is None or camera.type != "CAMERA":
        raise ValueError("the scene has no active camera (Scene properties > Camera)")
    data = camera.data
    if data.type not in {"PERSP", "ORTHO"} or data.shift_x or data.shift_y:
        raise ValueError(
            f"camera '{camera.name}': Occlux needs a perspective or orthographic camera "
            "without lens shift"
        )
    world = camera.matrix_world
    position = world.translation
    forward = -world.col[2].xyz.normalized()
    up = world.col[1].xyz.normalized()
    lines = [
        "[camera]",
        f"position = {_list(position)}",
        f"target = {_list(position + forward)}",
        f"up = {_list(up)}",
        f"width = {width}",
        f"height = {height}",
    ]
    depsgraph = bpy.context.evaluated_depsgraph_get()
    matrix = camera.calc_matrix_camera(depsgraph, x=width, y=height)
    if data.type == "PERSP":
        lines.append(f"fov_deg = {math.degrees(2.0 * math.atan(1.0 / matrix[1][1])):.9g}")
    else:  # Occlux's ortho_scale spans the larger image side, as Blender's AUTO fit
        half = 1.0 / matrix[0][0] if width >= height else 1.0 / matrix[1][1]
        lines += ['projection = "orthographic"', f"ortho_scale = {2.0 * half:.9g}"]
    return "\n".join(lines) + "\n"


def world_radiance(scene: bpy.types.Scene) -> tuple[float, float, float]:
    """The world's uniform radiance: its Background node's colour times strength (or the world
    colour without nodes). A textured world has no single value, and is refused."""
    world = scene.world
    if world is None:
        return (0.0, 0.0, 0.0)
    tree = world.node_tree
    output = tree and next((n for n in tree.nodes if n.bl_idname == "ShaderNodeOutputWorld"), None)
    if output is None or not output.inputs["Surface"].links:
        return tuple(world.color)
    background = output.inputs["Surface"].links[0].from_node
    colour, strength = background.inputs["Color"], background.inputs["Strength"]
    if background.bl_idname != "ShaderNodeBackground" or colour.links or strength.links:
        raise ValueError(
            f"world '{world.name}': Occlux needs a plain Background colour (no texture)"
        )
    return tuple(c * strength.default_value for c in colour.default_value[:3])


def lights_toml(scene: bpy.types.Scene, ambient_only: bool) -> str:
    """The world as an ambient light and, unless `ambient_only`, the visible sun lights as
    directional lights (irradiance = strength x colour, towards the sun's +Z)."""
    ambient = world_radiance(scene)
    blocks = []
    if max(ambient) > 0.0:
        blocks.append(f'[[lights]]\ntype = "ambient"\nradiance = {_list(ambient)}\n')
    for obj in scene.objects:
        if obj.type != "LIGHT" or obj.hide_render:
            continue
        if ambient_only or obj.data.type != "SUN":
            kind = "only the world's ambient light" if ambient_only else "sun lights"
            raise ValueError(f"light '{obj.name}': this takes {kind}; hide it from renders")
        irradiance = [c * obj.data.energy for c in obj.data.color]
        direction = obj.matrix_world.col[2].xyz.normalized()
        blocks.append(
            f'[[lights]]\ntype = "directional"\ndirection = {_list(direction)}\n'
            f"irradiance = {_list(irradiance)}\n"
        )
    if not blocks:
        raise ValueError("the scene has no light: give the world a colour or add a sun")
    return "background = " + _list(ambient) + "\n" + "".join(blocks)


def volume_toml(source, settings) -> str:
    """The volume section: the file, fitted and centred as the add-on places it, classified by
    the preset."""
    lines = [
        "[volume]",
        f"path = {json.dumps(str(Path(source.path).resolve()))}",
        f"fit = {source.fit:.9g}",
        "centre = [0, 0, 0]",
    ]
    if Path(source.path).suffix.lower() == ".raw":
        lines += [
            "[volume.raw]",
            f"dims = {json.dumps(list(source.raw_dims))}",
            f'type = "{source.raw_type}"',
            f"spacing = {_list(source.raw_spacing)}",
        ]
    lines += [
        "[classification]",
        f'preset = "{settings.preset}"',
        f"density_scale = {settings.density_scale:.9g}",
    ]
    return "\n".join(lines) + "\n"


def scene_toml(
    context: bpy.types.Context, source, width: int, height: int, ambient_only: bool = False
) -> str:
    """The whole scene file for the scene's volume settings, camera and lights."""
    scene = context.scene
    return (
        lights_toml(scene, ambient_only)
        + volume_toml(source, scene.occlux)
        + camera_toml(scene, width, height)
    )
