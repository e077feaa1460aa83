"""Volume import and ambient occlusion: load and classify the volume file into the scene as a
Volume object, and compute its ambient occlusion into an `ao` grid that shades its material.
One dataset is one object: Compute AO gives the object it acts on (the active Occlux volume,
else the one of the panel's file) a VDB holding all its grids, never a second object. `show`
makes the Volume object and its material for these and for Load Series (`series.py`)."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import bpy
import occlux

from .. import material, scenes
from .jobs import JobProgress, OccluxJob, output_dir


@dataclass(frozen=True)
class Loaded:
    """A VDB written by a job, with what its material needs."""

    vdb: Path
    source: scenes.VolumeInput
    classification: Any
    volume: Any


def write_grids(vdb: Path, grids: dict) -> None:
    """The core's writer, atomic (a temporary file in the folder, renamed when complete): a
    cancelled or failed job never leaves a partial file under the name Blender would load."""
    vdb.parent.mkdir(parents=True, exist_ok=True)
    occlux.write_vdb(vdb, grids)


class OCCLUX_OT_import_volume(OccluxJob, bpy.types.Operator):
    """Load the volume file, classify it with the preset and add it as a Volume object"""

    bl_idname = "occlux.import_volume"
    bl_label = "Load Volume"
    bl_options = {"REGISTER", "UNDO"}

    def prepare(self, context: bpy.types.Context) -> Callable[[JobProgress], Loaded]:
        settings = context.scene.occlux
        source = scenes.VolumeInput.from_settings(settings)
        scene = scenes.build(scenes.volume_tree(source, settings))
        vdb = output_dir(settings) / f"{source.stem}.vdb"

        def work(progress: JobProgress) -> Loaded:
            volume = scenes.load_volume(scene, source)
            classification = scene.classification
            density = classification.extinction(volume)
            write_grids(vdb, {"density": density, "value": volume})
            return Loaded(vdb, source, classification, volume)

        return work

    def finish(self, context: bpy.types.Context, result: Loaded) -> str:
        obj = show_volume(context, result, None, None)
        return f"loaded {result.source.path.name} as '{obj.name}' ({result.vdb})"


# The AO methods that compute the visibility (no radius: they reach the whole volume).
VISIBILITY = ("ordinates", "sweep-physical")

# The octants' intensities of each `ao_light` (the `ao_oct` order: bit 2 set looks down -z).
OCTANT_INTENSITIES = {"ambient": [1.0] * 8, "sky": [1.0] * 4 + [0.0] * 4}


def ao_options(settings: bpy.types.PropertyGroup) -> dict:
    """`occlux.ao_volume`'s keyword arguments for the panel's AO method."""
    if settings.ao_method == "sweep":
        return {
            "gamma": settings.ao_gamma,
            "alpha": settings.ao_alpha,
            "octant_intensities": OCTANT_INTENSITIES[settings.ao_light],
        }
    if settings.ao_method in VISIBILITY:
        return {}
    return {"radius": settings.ao_radius}


def ao_section(settings: bpy.types.PropertyGroup) -> dict:
    """The `render` section of an AO-shaded render (`method = "ao"`) with the panel's AO
    method, lit by the ambient light alone (no direct light)."""
    section = {"method": "ao", "ao_method": settings.ao_method, "direct": False}
    if settings.ao_method == "sweep":
        section.update(
            ao_gamma=settings.ao_gamma, ao_alpha=settings.ao_alpha, ao_light=settings.ao_light
        )
    elif settings.ao_method not in VISIBILITY:
        section["ao_radius"] = settings.ao_radius
    return section


def ao_label(settings: bpy.types.PropertyGroup) -> str:
    """The AO method as the status line says it."""
    if settings.ao_method == "sweep" or settings.ao_method in VISIBILITY:
        return settings.ao_method
    return f"{settings.ao_method}, radius {settings.ao_radius}"


class OCCLUX_OT_compute_ao(OccluxJob, bpy.types.Operator):
    """Compute the volume's ambient occlusion (VAO or occlusion sweeping) with Occlux and add
    it as a Volume object whose material is shaded by the `ao` grid"""

    bl_idname = "occlux.compute_ao"
    bl_label = "Compute AO"
    bl_options = {"REGISTER", "UNDO"}

    def prepare(self, context: bpy.types.Context) -> Callable[[JobProgress], Loaded]:
        settings = context.scene.occlux
        source = scenes.selected_source(context)
        target = scenes.volume_object(context)
        # By name: the object may go while the work runs (then the file's object is found).
        self._target = None if target is None else target.name
        scene = scenes.build(scenes.volume_tree(source, settings))
        method, options, device = settings.ao_method, ao_options(settings), settings.device
        vdb = output_dir(settings) / f"{source.stem}-ao.vdb"

        def work(progress: JobProgress) -> Loaded:
            volume = scenes.load_volume(scene, source)
            computed = occlux.ao_volume(
                scene, method=method, device=device, volume=volume, progress=progress, **options
            )
            classification = scene.classification
            density = classification.extinction(volume)
            # The sweep's signed distance goes along as a level set (`sdf`).
            grids = {"density": density, "value": volume, "ao": computed["ao"]}
            grids.update((name, computed[name]) for name in ("sdf",) if name in computed)
            write_grids(vdb, grids)
            return Loaded(vdb, source, classification, volume)

        return work

    def finish(self, context: bpy.types.Context, result: Loaded) -> str:
        settings = context.scene.occlux
        target = bpy.data.objects.get(self._target) if self._target else None
        obj = show_volume(context, result, settings.ao_shading, target)
        source = result.source.path.name
        return f"AO ({ao_label(settings)}) of {source} on '{obj.name}' ({result.vdb})"


# The custom properties that mark the Volume objects Occlux shows: a dataset's (the volume file
# as typed, which the operators act on) and a series' (its manifest: `series.py`).
SOURCE, SERIES = "occlux_source", "occlux_series"


@dataclass(frozen=True)
class FrameSequence:
    """A VDB per frame, numbered in the file names as Blender's volume sequences are (the
    digits just before `.vdb`, zero-padded): `count` files from the number `first`."""

    count: int
    first: int


@dataclass(frozen=True)
class Shown:
    """What a Volume object shows: the VDB (the first frame's, for a `sequence`) with the
    `grids` it must hold, the material's control points (None: a 2D transfer function), and
    the custom property `mark` that marks the object, holding `setting`. `owned`: the add-on
    wrote the VDB, so a file Blender cannot read is removed (a series' files are the user's).
    `box`: the volume's cells' bounds, where its medium ends (the material's box mask)."""

    name: str
    vdb: Path
    grids: tuple[str, ...]
    points: Sequence[material.Point] | None
    mark: str
    setting: str
    owned: bool
    box: tuple[material.Rgb, material.Rgb]
    sequence: FrameSequence | None = None


def show_volume(
    context: bpy.types.Context, loaded: Loaded, ao: str | None, target: bpy.types.Object | None
) -> bpy.types.Object:
    """The dataset's Volume object (`show`) for a VDB a job wrote."""
    grids = ("density", "value") + (() if ao is None else ("ao",))
    return show(context, dataset_shown(loaded, grids), ao, target)


def dataset_shown(loaded: Loaded, grids: tuple[str, ...]) -> Shown:
    """What the dataset's object shows of a VDB a job wrote (the add-on's own file) holding
    `grids`."""
    return Shown(
        name=loaded.source.stem,
        vdb=loaded.vdb,
        grids=grids,
        points=loaded.classification.raw_points(loaded.volume),
        box=loaded.volume.bounds,
        mark=SOURCE,
        setting=loaded.source.setting,
        owned=True,
    )


def show(
    context: bpy.types.Context,
    shown: Shown,
    ao: str | None,
    target: bpy.types.Object | None,
    shading: Callable[[str], bpy.types.Material] | None = None,
) -> bpy.types.Object:
    """The Volume object shows the VDB with the Occlux material (AO-shaded by `ao`; or the one
    `shading` makes, given its name): `target`
    (the object the operator acted on), else the object of the same name that carries the same
    mark, else a new one. An existing object keeps its transform, visibility and name; its
    previous data and material go if nothing else uses them. The object is made active and
    selected. If Blender cannot read the file, or it lacks one of the grids, nothing changes
    (and an owned file is removed)."""
    name = shown.name
    if ao == "AMBIENT":  # before anything is added: a textured world is refused, nothing made
        scenes.world_radiance(context.scene)
    data = bpy.data.volumes.new(name)
    data.filepath = str(shown.vdb)
    # Cycles reads the grids at full precision, none clipped as empty: Occlux's values.
    data.render.precision = "FULL"
    data.render.clipping = 0.0
    error = None if data.grids.load() else data.grids.error_message
    missing = [g for g in shown.grids if g not in data.grids]
    if error is None and missing:
        error = f"no grid {', '.join(missing)} (it holds {', '.join(data.grids.keys())})"
    if error is not None:
        bpy.data.volumes.remove(data)
        if shown.owned:
            shown.vdb.unlink(missing_ok=True)
        raise OSError(f"Blender cannot read {shown.vdb}: {error}")
    if shown.sequence is not None:
        show_sequence(context.scene, data, shown.sequence)
    if shading is None:
        made = material.volume_material(
            f"Occlux {name}",
            shown.points,
            ao,
            context.scene.occlux.ao_factor,
            context.scene.world,
            shown.box,
        )
    else:
        made = shading(f"Occlux {name}")
    data.materials.append(made)
    obj = target
    if obj is None:
        same = bpy.data.objects.get(name)
        if same is not None and same.type == "VOLUME" and shown.mark in same:
            obj = same
    if obj is None:
        obj = bpy.data.objects.new(name, data)
        context.scene.collection.objects.link(obj)
    else:
        previous, obj.data = obj.data, data
        release(previous)
        made.name = f"Occlux {name}"  # the released material's name, free again
    obj[shown.mark] = shown.setting
    # A material of AMBIENT shading carries the world's light, so the world lights only camera
    # rays while one shows; otherwise (e.g. shading switched to ALBEDO) it lights every ray.
    if any(material.carries_ambient(o.active_material) for o in context.scene.objects):
        material.camera_only_world(context.scene)
    elif context.scene.world is not None:
        material.all_rays(context.scene.world)
    for other in context.view_layer.objects:
        other.select_set(False)
    # After the loop: a new object's base may not be in the view layer's list yet.
    context.view_layer.objects.active = obj
    obj.select_set(True)
    return obj


def show_sequence(scene: bpy.types.Scene, data: bpy.types.Volume, sequence: FrameSequence) -> None:
    """Makes the volume play its files from the scene's first frame: at scene frame f Blender
    loads the file numbered f - frame_start + 1 + frame_offset (the digits before `.vdb` put in
    its path), so frame_start shows the first file. CLIP shows nothing outside the sequence's
    frames rather than holding or repeating one, so a frame never shows another time's data."""
    data.is_sequence = True
    data.frame_start = scene.frame_start
    data.frame_duration = sequence.count
    data.frame_offset = sequence.first - 1
    data.sequence_mode = "CLIP"


def release(data: bpy.types.Volume) -> None:
    """Removes a volume's data and its materials once no object uses them."""
    if data.users:
        return
    shadings = [m for m in data.materials if m is not None]
    bpy.data.volumes.remove(data)
    for shading in shadings:
        if not shading.users:
            bpy.data.materials.remove(shading)


CLASSES = (OCCLUX_OT_import_volume, OCCLUX_OT_compute_ao)
