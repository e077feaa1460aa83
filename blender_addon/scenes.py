"""The Blender scene as an Occlux scene: the volume settings, the active camera and the lights
as the scene file's tree (plain Python data: `volume`, `classification`, `camera`, `lights`,
`background`, `render`), which `occlux.Scene.from_dict` validates as it validates a file. Read on
the main thread; the jobs hand the tree (or the scene built from it) to the core and to the
Cycles mapping (`occlux.blender`), which map it back onto Blender the same way."""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import bpy
import occlux
from mathutils import Matrix, Vector

from . import transfer
from .material import world_shader

# The add-on maps the world to an ambient light, sun lamps to directional lights and point lamps
# to point lights; these are the kinds of the registry's `lights` it can give a method.
WORLD, SUN, POINT = "ambient", "directional", "point"

# What each kind of lamp is called in messages.
LAMP_NAMES = {SUN: "sun lights", POINT: "point lights"}

# A camera for scenes whose camera is unused (`occlux.ao_volume` reads only the volume and the
# classification); the scene file requires one.
UNUSED_CAMERA = {"position": [0.0, -4.0, 0.0]}


def _floats(values: Iterable[float]) -> list[float]:
    return [float(v) for v in values]


def method(name: str) -> dict[str, Any]:
    """The core's registry entry of a rendering method (`occlux.methods()`)."""
    for entry in occlux.methods():
        if entry["name"] == name:
            return entry
    raise KeyError(f"the Occlux core has no method '{name}'")


@dataclass(frozen=True)
class VolumeInput:
    """The volume settings, read on the main thread so that the work needs no Blender data."""

    path: Path
    setting: str  # the path as the user typed it, kept on the object
    raw_dims: tuple[int, int, int]
    raw_type: str
    raw_spacing: tuple[float, float, float]
    fit: float
    memory_budget_mb: int

    @staticmethod
    def from_settings(settings, path: str | None = None) -> VolumeInput:
        """The panel's volume settings, for the file `path` as typed (the panel's Volume if
        None)."""
        typed = settings.volume_path if path is None else path
        if not typed:
            raise FileNotFoundError("no volume file set (Occlux panel > Volume)")
        resolved = Path(bpy.path.abspath(typed))
        if not resolved.is_file():
            raise FileNotFoundError(f"no volume file at '{resolved}'")
        return VolumeInput(
            resolved.resolve(),
            typed,
            tuple(settings.raw_dims),
            settings.raw_type,
            tuple(settings.raw_spacing),
            settings.fit,
            settings.memory_budget_mb,
        )

    @property
    def stem(self) -> str:
        return self.path.name.split(".")[0]

    def section(self) -> dict[str, Any]:
        """The scene's `volume` section: the file, fitted and centred as the add-on places it,
        with the panel's raw layout and memory budget (which the core's loaders check from the
        file's header, before reading any voxel)."""
        section: dict[str, Any] = {
            "path": str(self.path),
            "fit": float(self.fit),
            "centre": [0.0, 0.0, 0.0],
            "memory_budget_gib": self.memory_budget_mb / 1024.0,
        }
        if self.path.suffix.lower() == ".raw":
            section["raw"] = {
                "dims": [int(n) for n in self.raw_dims],
                "type": self.raw_type,
                "spacing": _floats(self.raw_spacing),
            }
        return section


def volume_object(context: bpy.types.Context) -> bpy.types.Object | None:
    """The active object if it is a volume Occlux loaded (it keeps its file as
    `occlux_source`): the object the operators act on."""
    obj = context.view_layer.objects.active
    if obj is not None and obj.type == "VOLUME" and "occlux_source" in obj:
        return obj
    return None


def selected_source(context: bpy.types.Context) -> VolumeInput:
    """The volume the operators act on: the active Occlux volume object's file, else the
    panel's Volume (with the panel's raw layout, size and memory budget either way)."""
    obj = volume_object(context)
    path = None if obj is None else str(obj["occlux_source"])
    return VolumeInput.from_settings(context.scene.occlux, path)


def dataset_object(context: bpy.types.Context, source: VolumeInput) -> bpy.types.Object | None:
    """The Volume object that shows `source` in the scene: the active Occlux volume, else the
    first of the scene's Occlux volumes loaded from the same file; None if none does."""
    return volume_object(context) or file_object(context, source)


def file_object(context: bpy.types.Context, source: VolumeInput) -> bpy.types.Object | None:
    """The scene's Occlux volume loaded from `source`'s file (the active object first); None if
    none is."""
    for obj in (context.view_layer.objects.active, *context.scene.objects):
        if obj is not None and obj.type == "VOLUME" and "occlux_source" in obj:
            if Path(bpy.path.abspath(str(obj["occlux_source"]))).resolve() == source.path:
                return obj
    return None


def panel_dataset(context: bpy.types.Context) -> tuple[VolumeInput, bpy.types.Object | None]:
    """The volume Compute AO acts on, and the object showing it (None: none yet): the panel's
    Volume when it is set, on its own object (the active Occlux volume only if that shows the
    same file), so that a file typed into the panel is the one whose AO is computed, and the
    active object of another file is left alone; with the Volume field empty, the active
    Occlux volume and its file."""
    active = volume_object(context)
    if active is not None and not context.scene.occlux.volume_path:
        return selected_source(context), active
    source = VolumeInput.from_settings(context.scene.occlux)
    return source, file_object(context, source)


def classification_section(settings) -> dict[str, Any]:
    """The scene's `classification`: the panel's preset or ramp (`transfer.section`)."""
    return transfer.section(settings)


def camera_section(scene: bpy.types.Scene, width: int, height: int) -> dict[str, Any]:
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
    # The evaluated depsgraph first: it brings matrix_world up to date with the camera's
    # location and rotation (a script may just have set them).
    depsgraph = bpy.context.evaluated_depsgraph_get()
    world = camera.matrix_world
    position = world.translation
    forward = -world.col[2].xyz.normalized()
    section: dict[str, Any] = {
        "position": _floats(position),
        "target": _floats(position + forward),
        "up": _floats(world.col[1].xyz.normalized()),
        "width": int(width),
        "height": int(height),
    }
    matrix = camera.calc_matrix_camera(depsgraph, x=width, y=height)
    if data.type == "PERSP":
        section["fov_deg"] = math.degrees(2.0 * math.atan(1.0 / matrix[1][1]))
    else:  # Occlux's ortho_scale spans the larger image side, as Blender's AUTO fit
        half = 1.0 / matrix[0][0] if width >= height else 1.0 / matrix[1][1]
        section["projection"] = "orthographic"
        section["ortho_scale"] = 2.0 * half
    return section


def world_radiance(scene: bpy.types.Scene) -> tuple[float, float, float]:
    """The world's uniform radiance: its Background node's colour times strength (or the world
    colour without nodes). A textured world has no single value, and is refused."""
    world = scene.world
    if world is None:
        return (0.0, 0.0, 0.0)
    background = world_shader(world)
    if background is None:
        return tuple(world.color)
    colour, strength = background.inputs["Color"], background.inputs["Strength"]
    if background.bl_idname != "ShaderNodeBackground" or colour.links or strength.links:
        raise ValueError(
            f"world '{world.name}': Occlux needs a plain Background colour (no texture)"
        )
    return tuple(c * strength.default_value for c in colour.default_value[:3])


def lamp(obj: bpy.types.Object, kinds: set[str]) -> dict[str, Any] | None:
    """A visible lamp as a light of `kinds`: a sun as a directional light (irradiance = strength
    x colour, towards the sun's +Z), a point lamp as a point light of radiant intensity
    power / (4 pi) x colour (Cycles' convention; its radius is not modelled: hard shadows).
    None for a lamp the method does not render, or that the add-on does not map (spot, area)."""
    if obj.data.type == "SUN" and SUN in kinds:
        return {
            "type": SUN,
            "direction": _floats(obj.matrix_world.col[2].xyz.normalized()),
            "irradiance": [c * obj.data.energy for c in obj.data.color],
        }
    if obj.data.type == "POINT" and POINT in kinds:
        return {
            "type": POINT,
            "position": _floats(obj.matrix_world.translation),
            "intensity": [c * obj.data.energy / (4.0 * math.pi) for c in obj.data.color],
        }
    return None


def takes(kinds: set[str]) -> str:
    """The lights of `kinds` as a message names them."""
    names = (["the world's ambient light"] if WORLD in kinds else []) + [
        LAMP_NAMES[k] for k in (SUN, POINT) if k in kinds
    ]
    return " and ".join(names) if names else "no light"


@dataclass(frozen=True)
class Lighting:
    """The scene's `background` and `lights`, and a note naming the visible lamps the method
    leaves out (empty when it renders them all)."""

    section: dict[str, Any]
    left_out: str


def lighting(scene: bpy.types.Scene, kinds: Iterable[str]) -> Lighting:
    """The `background` and `lights` of the scene: the world as an ambient light (when the
    method renders ambient light; it stays the background either way) and the visible lamps
    (`lamp`). `kinds` are the light kinds the method renders (its registry entry's `lights`); a
    lamp the method cannot render, or that the add-on does not map, is left out and named in
    the note, so that Blender's default Light does not stop a render lit by the world."""
    kinds = set(kinds)
    ambient = _floats(world_radiance(scene))
    lights: list[dict[str, Any]] = []
    if WORLD in kinds and max(ambient) > 0.0:
        lights.append({"type": WORLD, "radiance": ambient})
    skipped: list[str] = []
    for obj in scene.objects:
        if obj.type == "LIGHT" and not obj.hide_render:
            light = lamp(obj, kinds)
            if light is None:
                skipped.append(f"'{obj.name}' ({obj.data.type.lower()})")
            else:
                lights.append(light)
    if not lights:
        wanted = ["give the world a colour"] if WORLD in kinds else []
        wanted += [f"add a {LAMP_NAMES[k][:-1]}" for k in (SUN, POINT) if k in kinds]
        raise ValueError(f"the scene has no light: {' or '.join(wanted)}")
    note = ""
    if skipped:
        lamps = ", ".join(skipped)
        note = f"left out light {lamps}: this method renders {takes(kinds)}"
    return Lighting({"background": ambient, "lights": lights}, note)


@dataclass(frozen=True)
class Described:
    """The scene file's tree of a Blender scene, and what of the scene it leaves out."""

    tree: dict[str, Any]
    left_out: str


def scene_tree(
    context: bpy.types.Context,
    source: VolumeInput,
    width: int,
    height: int,
    kinds: Iterable[str] = (WORLD, SUN),
    render: dict[str, Any] | None = None,
) -> Described:
    """The whole scene for the scene's volume settings, camera and lights (of `kinds`), and the
    `render` section (the method and its parameters) if given."""
    scene = context.scene
    lights = lighting(scene, kinds)
    tree = {
        "volume": source.section(),
        "classification": classification_section(scene.occlux),
        "camera": camera_section(scene, width, height),
        **lights.section,
    }
    if render is not None:
        tree["render"] = render
    return Described(tree, lights.left_out)


def volume_tree(source: VolumeInput, settings) -> dict[str, Any]:
    """A scene of the volume and its classification alone (the camera is unused): what
    `occlux.ao_volume` and the volume operators need."""
    return {
        "volume": source.section(),
        "classification": classification_section(settings),
        "camera": dict(UNUSED_CAMERA),
    }


def framed_camera(scene: bpy.types.Scene) -> dict[str, Any]:
    """The scene camera's section at the render's size, asking the core to frame the visible
    content from the camera's direction (`frame = "content"`, its default margin) when the
    volume is settled."""
    render = scene.render
    percent = render.resolution_percentage / 100.0
    width, height = round(render.resolution_x * percent), round(render.resolution_y * percent)
    return {**camera_section(scene, width, height), "frame": "content"}


def place_camera(camera: bpy.types.Object, described: dict[str, Any]) -> None:
    """Moves and turns `camera` to the core's camera `described` (`Scene.describe()`'s):
    its eye at `position`, looking along `forward` with `up` up (Blender's camera looks down
    its local -Z with +Y up); its lens stays."""
    forward = Vector(described["forward"]).normalized()
    up = Vector(described["up"]).normalized()
    right = forward.cross(up).normalized()
    up = right.cross(forward)
    rotation = Matrix((right, up, -forward)).transposed()
    camera.matrix_world = Matrix.Translation(described["position"]) @ rotation.to_4x4()


def build(tree: dict[str, Any]) -> occlux.Scene:
    """The core's scene for `tree`, validated as a scene file is (errors name the key)."""
    return occlux.Scene.from_dict(tree)


def load_volume(scene: occlux.Scene, source: VolumeInput, settle: bool = False) -> occlux.Volume:
    """The scene's volume through the core's loaders (raw layout, budget, fit and centre); with
    `settle`, also what depends on the data settled in `scene` as `occlux render` settles it
    (its camera framed when the tree asks, `framed_camera`). The core states the budget in GiB
    or MiB; a refusal also names the panel's setting, in its MB."""
    try:
        return scene.settle()[0] if settle else scene.load_volume()
    except occlux.OccluxError as e:
        if "available (volume.memory_budget_gib)" not in str(e):
            raise
        raise occlux.OccluxError(
            f"{e} (Memory budget in the Occlux panel: {source.memory_budget_mb} MB)"
        ) from e
