"""Cycles' truth of an Occlux figure, made from the user's own scene: the dataset's Volume object
with its material, the scene's camera, world and the lamps the checked method renders. They go
into a scene of the Cycles mapping (named with `occlux.blender.PREFIX`, so that
`occlux.blender.remove_built` removes it and nothing of the user's): the camera and the lamps
linked as they are, the volume object, its material and the world as copies, set up as the
mapping sets up its own scenes (unbiased CPU path tracing into a linear EXR).

The copies differ from the user's data in what the check compares, and only there:
- the AO baked into the material (the `ao` grid's AMBIENT emission or ALBEDO darkening) is off,
  because the path tracer computes the occlusion itself (`material.without_ao`); the phase
  asymmetry is the checked method's;
- the world lights every ray for the methods lit by it (AO, DOS), and only camera rays (it stays
  the background) for IPSVI, which is lit by the lamps alone.

Plain data API (no operators), so it works headless."""

from __future__ import annotations

from collections.abc import Callable, Iterable
from dataclasses import dataclass

import bpy
import occlux.blender as ob
from mathutils import Matrix

from . import material, scenes

# Object types that render nothing themselves; any other visible object that is not the
# checked volume is named as left out of the check.
RENDERS_NOTHING = {"CAMERA", "LIGHT", "EMPTY", "ARMATURE", "LATTICE", "SPEAKER", "LIGHT_PROBE"}


@dataclass(frozen=True)
class Truth:
    """The Cycles mapping's scene of the figure, what it holds of the user's scene (for the report)
    and notes on what it leaves out or where Occlux's scene differs."""

    scene: bpy.types.Scene
    holds: dict
    notes: list[str]


def figure_truth(
    context: bpy.types.Context,
    obj: bpy.types.Object,
    kinds: Iterable[str],
    bounces: int,
    g: float,
    size: tuple[int, int],
    plain: Callable[[], bpy.types.Material] | None = None,
) -> Truth:
    """The scene of `context` with the volume object `obj`, as Cycles' truth of a method lit by
    the lights of `kinds` (`scenes.WORLD`, `SUN`, `POINT`), with `bounces` volume bounces and
    phase asymmetry `g`, rendered at `size` (width, height). The volume shows its own materials
    with the AO off, or the material that `plain` makes in every slot (the check of a baked
    scene: its unbaked material, named with the harness's prefix so that it goes with the rest).
    Data of a previous build goes first."""
    kinds = set(kinds)
    user = context.scene
    ob.remove_built()
    truth = bpy.data.scenes.new(f"{ob.PREFIX}-figure")
    volume = _volume_copy(obj, g, None if plain is None else plain())
    truth.collection.objects.link(volume)
    truth.collection.objects.link(user.camera)
    truth.camera = user.camera
    lamps = [
        o
        for o in user.objects
        if o.type == "LIGHT" and not o.hide_render and scenes.lamp(o, kinds) is not None
    ]
    for lamp in lamps:
        truth.collection.objects.link(lamp)
    if user.world is not None:
        truth.world = user.world.copy()
        truth.world.name = f"{ob.PREFIX}-world"
        if scenes.WORLD in kinds:
            material.all_rays(truth.world)
        else:
            material.camera_only(truth.world)
    truth.frame_current = user.frame_current  # an animated camera or lamp where the user sees it
    truth.render.resolution_x, truth.render.resolution_y = size
    ob.cycles_settings(truth, bounces)
    holds = {
        "volume_object": obj.name,
        "materials": [s.material.name for s in obj.material_slots if s.material],
        "world": user.world.name if user.world else None,
        "lamps": [lamp.name for lamp in lamps],
        "camera": user.camera.name,
    }
    return Truth(truth, holds, _notes(user, obj, placed_by_occlux=plain is None))


def _volume_copy(
    obj: bpy.types.Object, g: float, plain: bpy.types.Material | None
) -> bpy.types.Object:
    """A copy of the volume object (same data, same transform) whose material slots hold copies
    of its materials with the AO off (`material.without_ao`), or `plain`."""
    shadings = [slot.material for slot in obj.material_slots]
    if not any(shadings):
        raise ValueError(f"the volume object '{obj.name}' has no material: load it again")
    copy = obj.copy()
    copy.name = f"{ob.PREFIX}-volume"
    for slot, shading in zip(copy.material_slots, shadings, strict=True):
        if shading is None:
            continue
        if plain is None:
            truth_shading = shading.copy()
            truth_shading.name = f"{ob.PREFIX}-{shading.name}"
        else:
            truth_shading = plain
        material.without_ao(truth_shading, g)
        slot.link = "OBJECT"  # the copy's own material; the shared data keeps the user's
        slot.material = truth_shading
    return copy


def _notes(user: bpy.types.Scene, obj: bpy.types.Object, placed_by_occlux: bool) -> list[str]:
    """What the check leaves out of the user's scene, and a moved volume object where the check
    compares with Occlux's render (`placed_by_occlux`: Occlux renders the volume where Load
    Volume placed it)."""
    notes = []
    others = [
        o.name
        for o in user.objects
        if o is not obj and o.type not in RENDERS_NOTHING and not o.hide_render
    ]
    if others:
        names = ", ".join(f"'{name}'" for name in others)
        notes.append(f"not in the check: {names} (Occlux renders the volume alone)")
    if not placed_by_occlux:
        return notes
    identity = Matrix.Identity(4)
    moved = any(
        abs(obj.matrix_world[i][j] - identity[i][j]) > 1e-6 for i in range(4) for j in range(4)
    )
    if moved:
        notes.append(
            f"the volume object '{obj.name}' is moved, rotated or scaled: Occlux renders the "
            "volume where Load Volume placed it (Object > Clear > All to match)"
        )
    return notes
