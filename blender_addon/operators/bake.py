"""Bake Light: the light of the scene's world, suns and point lamps baked into grids of the
active Occlux volume (`occlux.bake`: the ambient visibility `ao`, per lamp the light reaching
each voxel and its multiply scattered light), shown by a material that emits it
(`material.baked_material`), so that EEVEE and Cycles render the volume's light without
tracing its shadows.

So that no light is counted twice, the baked lamps stop lighting the volume (light linking:
each lamp's receiver collection excludes the volume object; Cycles and EEVEE both honour it)
and the world lights only camera rays (it stays the background), as the ambient-light AO
material does. What a new bake needs (a lamp moved, added or removed, the classification
changed) is detected by `outdated` and shown in the panel; strengths and colours are read by
the material's drivers and need none. The EEVEE settings a bake needs are set by `eevee_for`
and restored by Restore EEVEE Settings (`eevee.restore`)."""

from __future__ import annotations

import json
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import bpy
import occlux
from mathutils import Vector

from .. import eevee, material, scenes
from .jobs import JobProgress, OccluxJob
from .volume import PLAIN, Loaded, dataset_shown, named_vdb, show, write_grids

# The object's custom property holding what its bake saw (`fingerprint`).
BAKED = "occlux_bake"
# The lamp types a bake holds (`scenes.lamp` maps them).
BAKED_TYPES = {"SUN": scenes.SUN, "POINT": scenes.POINT}


def baked_lamps(scene: bpy.types.Scene) -> list[bpy.types.Object]:
    """The scene's visible suns and point lamps, by name (the bake's order)."""
    return sorted(
        (
            o
            for o in scene.objects
            if o.type == "LIGHT" and not o.hide_render and o.data.type in BAKED_TYPES
        ),
        key=lambda o: o.name,
    )


def fingerprint(context: bpy.types.Context, lamps: list[bpy.types.Object]) -> dict:
    """What a bake depends on beyond strengths and colours: each lamp's name, type and place,
    the volume file and its classification, the phase asymmetry and whether multiple scattering
    is baked."""
    settings = context.scene.occlux
    return {
        "lamps": [
            [o.name, o.data.type, [round(x, 6) for row in o.matrix_world for x in row]]
            for o in lamps
        ],
        "source": scenes.selected_source(context).setting,
        "classification": scenes.classification_section(settings),
        "scattering": {"g": round(settings.ipsvi_g, 6), "multiple": settings.bake_multiple},
    }


def outdated(context: bpy.types.Context, obj: bpy.types.Object | None) -> str:
    """Why the baked object `obj` needs a new bake ("" when it does not, or was not baked)."""
    if obj is None or BAKED not in obj:
        return ""
    before = json.loads(obj[BAKED])
    try:
        now = fingerprint(context, baked_lamps(context.scene))
    except ValueError as e:  # the panel's classification cannot be applied as it stands
        return f"the classification changed, and cannot be applied: {e}"
    if now["source"] != before["source"] or now["classification"] != before["classification"]:
        return "the volume or its classification changed"
    if now["scattering"] != before.get("scattering"):
        return "the anisotropy or Multiple scattering changed"
    was = {name: (kind, place) for name, kind, place in before["lamps"]}
    is_ = {name: (kind, place) for name, kind, place in now["lamps"]}
    for name in sorted(was.keys() | is_.keys()):
        if name not in is_:
            return f"lamp '{name}' is gone"
        if name not in was:
            return f"lamp '{name}' is new"
        if was[name] != is_[name]:
            return f"lamp '{name}' moved"
    return ""


def lamp_section(obj: bpy.types.Object, lamp: bpy.types.Object) -> dict:
    """The lamp as a light of the volume's own space (where Occlux's grids are): the inverse of
    the object's transform applied. A scaled object is refused: its grids' distances and
    extinction would not be the scene's."""
    scale = obj.matrix_world.to_scale()
    if any(abs(s - 1.0) > 1e-6 for s in scale):
        raise ValueError(
            f"Bake Light needs the volume object '{obj.name}' unscaled (its scale is "
            f"{tuple(round(s, 4) for s in scale)}): apply or clear its scale"
        )
    light = scenes.lamp(lamp, set(BAKED_TYPES.values()))
    inverse = obj.matrix_world.inverted()
    if "direction" in light:
        direction = (inverse.to_3x3() @ lamp.matrix_world.col[2].xyz).normalized()
        light["direction"] = list(direction)
    else:
        light["position"] = list(inverse @ lamp.matrix_world.translation)
    return light


@dataclass(frozen=True)
class Baked:
    loaded: Loaded
    lamps: tuple[material.BakedLamp, ...]
    world_multiple: tuple[str, str, str] | None
    fingerprint: dict


class OCCLUX_OT_bake_light(OccluxJob, bpy.types.Operator):
    """Bake the world's, the suns' and the point lamps' light into the active Occlux volume's
    grids, shown by a material that emits it: EEVEE and Cycles then render its shadows and
    multiple scattering without tracing them"""

    bl_idname = "occlux.bake_light"
    bl_label = "Bake Light"
    bl_options = {"REGISTER", "UNDO"}

    def prepare(self, context: bpy.types.Context) -> Callable[[JobProgress], Baked]:
        settings = context.scene.occlux
        source = scenes.selected_source(context)
        target = scenes.volume_object(context)
        if target is None:
            raise ValueError("Bake Light needs an Occlux volume: Load Volume first")
        self._target = target.name
        # Refused here, with nothing made, rather than by the material.
        scenes.world_radiance(context.scene)
        lamps = baked_lamps(context.scene)
        tree = scenes.volume_tree(source, settings)
        tree["lights"] = [lamp_section(target, lamp) for lamp in lamps]
        scene = scenes.build(tree)
        seen = fingerprint(context, lamps)
        device, g, multiple = settings.device, settings.ipsvi_g, settings.bake_multiple
        # Named by what it holds, so a .blend baked with other settings keeps its own file.
        vdb = named_vdb(
            settings, source, "bake", {"lamps": seen["lamps"], "g": g, "multiple": multiple}
        )

        def work(progress: JobProgress) -> Baked:
            volume = scenes.load_volume(scene, source)
            grids = occlux.bake(
                scene, g=g, multiple=multiple, device=device, volume=volume, progress=progress
            )
            classification = scene.classification
            density = classification.extinction(volume)
            write_grids(vdb, {"density": density, "value": volume, **grids})
            baked = tuple(
                material.BakedLamp(
                    name=lamp.name,
                    kind=lamp.data.type,
                    grid=f"light{i}",
                    multiple=tuple(f"light{i}_multiple_{c}" for c in "rgb") if multiple else None,
                )
                for i, lamp in enumerate(lamps)
            )
            world = tuple(f"ao_multiple_{c}" for c in "rgb") if multiple else None
            return Baked(Loaded(vdb, source, classification, volume), baked, world, seen)

        return work

    def finish(self, context: bpy.types.Context, result: Baked) -> str:
        scene = context.scene
        loaded = result.loaded
        grids = (*PLAIN, "ao")
        for lamp in result.lamps:
            grids += (lamp.grid,) + (lamp.multiple or ())
        shown = dataset_shown(loaded, grids, result.fingerprint["classification"])
        target = bpy.data.objects.get(self._target)

        def shading(name: str) -> bpy.types.Material:
            return material.baked_material(
                name, shown.points, shown.box, scene.world, result.lamps, result.world_multiple
            )

        obj = show(context, shown, None, target, shading)
        obj[BAKED] = json.dumps(result.fingerprint)
        for lamp in result.lamps:
            exclude_from(bpy.data.objects[lamp.name], obj)
        changed = eevee_for(scene, obj)
        if not scene.cycles.volume_biased:
            # A baked volume only absorbs and emits: marching it in steps integrates its
            # emission along each ray with little noise, where Cycles' unbiased (null
            # scattering) sampling would need many samples.
            scene.cycles.volume_biased = True
            changed.append("Cycles volume_biased False -> True")
        told = f"; set {', '.join(changed)}" if changed else ""
        return (
            f"baked the world and {len(result.lamps)} lamp(s) into '{obj.name}' "
            f"({Path(loaded.vdb).name}){told}"
        )


def exclude_from(lamp: bpy.types.Object, obj: bpy.types.Object) -> None:
    """Keeps `lamp` from lighting `obj` (light linking): `obj` excluded in the lamp's receiver
    collection, which is made for it if the lamp has none (the lamp still lights every other
    object)."""
    collection = lamp.light_linking.receiver_collection
    if collection is None:
        collection = bpy.data.collections.new(f"Occlux: not lit by {lamp.name}")
        lamp.light_linking.receiver_collection = collection
    if obj.name not in collection.objects:
        collection.objects.link(obj)
    for member, link in zip(collection.objects, collection.collection_objects, strict=True):
        if member == obj:
            link.light_linking.link_state = "EXCLUDE"


# EEVEE's volume settings a bake needs: 256 depth slices and the finest froxels (1 pixel) that
# keep the froxel grid within EEVEE_FROXELS (its textures near 1 GiB: at 512^2 that is 2-pixel
# froxels), since the baked light varies at the volume's voxels and EEVEE's default 8-pixel
# froxels blur it (on the 64 x 48 phantom of tests/python/test_addon_bake.py 2-pixel froxels
# and 128 slices measured 0.12 under a sun and 0.16 under the world, 1 pixel and 256 slices
# 0.062 and 0.076); no volumetric shadows (the bake holds them); the range fitted to the
# object (`eevee_for`); and the indirect light in volumes unclamped (`eevee.UNCLAMPED`), as
# Load Volume sets it, for the volumes the bake leaves plain.
EEVEE_SLICES = 256
EEVEE_FROXELS = 1 << 25
EEVEE_TILES = ("1", "2", "4", "8", "16")


def froxel_tile(width: int, height: int) -> str:
    """The finest froxel size whose grid of EEVEE_SLICES slices fits EEVEE_FROXELS."""
    for tile in EEVEE_TILES:
        side = int(tile)
        if -(-width // side) * -(-height // side) * EEVEE_SLICES <= EEVEE_FROXELS:
            return tile
    return EEVEE_TILES[-1]


def eevee_for(scene: bpy.types.Scene, obj: bpy.types.Object) -> list[str]:
    """Sets EEVEE's volume settings for a baked `obj` seen by the scene's camera; remembers the
    user's (once, until restored) and returns what changed."""
    percent = scene.render.resolution_percentage / 100.0
    size = (round(scene.render.resolution_x * percent), round(scene.render.resolution_y * percent))
    wanted = {
        "volumetric_tile_size": froxel_tile(*size),
        "volumetric_samples": EEVEE_SLICES,
        "use_volumetric_shadows": False,
        **eevee.UNCLAMPED,
    }
    if scene.camera is not None:
        eye = scene.camera.matrix_world.translation
        corners = [obj.matrix_world @ Vector(c) for c in obj.bound_box]
        distances = [(c - eye).length for c in corners]
        wanted["use_volume_custom_range"] = True
        wanted["volumetric_start"] = max(0.9 * min(distances), 1e-3)
        wanted["volumetric_end"] = 1.1 * max(distances)
    return eevee.change(scene, wanted)


class OCCLUX_OT_restore_eevee(bpy.types.Operator):
    """Restore the EEVEE settings Load Volume and Bake Light changed"""

    bl_idname = "occlux.restore_eevee"
    bl_label = "Restore EEVEE Settings"
    bl_options = {"REGISTER", "UNDO"}

    def execute(self, context: bpy.types.Context) -> set[str]:
        if not eevee.restore(context.scene):
            self.report({"INFO"}, "Occlux changed no EEVEE setting")
            return {"CANCELLED"}
        self.report({"INFO"}, "restored the EEVEE settings")
        return {"FINISHED"}


CLASSES = (OCCLUX_OT_bake_light, OCCLUX_OT_restore_eevee)
