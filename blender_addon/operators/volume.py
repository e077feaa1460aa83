"""Volume import and ambient occlusion: load and classify the volume file into the scene as a
Volume object, and compute its ambient occlusion into an `ao` grid that shades its material.
One dataset is one object: Compute AO gives the object it acts on (the active Occlux volume,
else the one of the panel's file) a VDB holding all its grids, never a second object. `show`
makes the Volume object and its material for these and for Load Series (`series.py`)."""

from __future__ import annotations

import hashlib
import json
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import bpy
import numpy as np
import occlux

from .. import eevee, material, scenes, transfer
from .jobs import JobProgress, OccluxJob, output_dir


@dataclass(frozen=True)
class Loaded:
    """A VDB written by a job, with what its material needs."""

    vdb: Path
    source: scenes.VolumeInput
    classification: Any
    volume: Any
    # The core's camera framing the visible content (`Scene.describe()`'s), when asked.
    camera: dict | None = None


def named_vdb(settings, source: scenes.VolumeInput, kind: str, depends: dict) -> Path:
    """The VDB of `source` in the output folder named by what it holds, STEM-KIND-HASH.vdb
    (STEM-HASH.vdb without a `kind`): HASH is the first 12 hex digits of the SHA-256 of the
    volume as placed (the resolved file, its raw layout and size), its classification and
    `depends` (the method's settings). The same file with other settings gets another file, so
    a .blend saved earlier goes on rendering the grids it was made with."""
    volume = {k: v for k, v in source.section().items() if k != "memory_budget_gib"}
    holds = {"volume": volume, "classification": scenes.classification_section(settings)}
    text = json.dumps({**holds, **depends}, sort_keys=True)
    digest = hashlib.sha256(text.encode()).hexdigest()[:12]
    name = f"{source.stem}-{kind}-{digest}" if kind else f"{source.stem}-{digest}"
    return output_dir(settings) / f"{name}.vdb"


# Grids kept at float32: the extinction (any range) and the sweep's level set. The others (the
# visibility `ao` in [0, 1], the bake's light per unit strength) are stored as half floats when
# they fit (|v| <= HALF_MAX): 11 significant bits, a relative rounding of at most 2^-11 (4.9e-4),
# far below the noise of any render of them.
FULL_PRECISION = ("density", "sdf")
HALF_MAX = 65504.0
# A half float holds every integer up to 2^11 exactly: a scan's integer values (8-bit, or CT
# numbers to 2048) stored so lose nothing, so `value` is half when its values are such.
HALF_INTEGERS = 2048.0


def half_grids(grids: dict[str, occlux.Volume]) -> list[str]:
    """The grids that `write_grids` stores as half floats (see FULL_PRECISION)."""
    halves = []
    for name, volume in grids.items():
        values = np.asarray(volume.values)
        largest = float(np.abs(values).max())
        if name == "value":
            fits = largest <= HALF_INTEGERS and bool(np.all(values == np.round(values)))
        else:
            fits = name not in FULL_PRECISION and largest <= HALF_MAX
        if fits:
            halves.append(name)
    return halves


def write_grids(vdb: Path, grids: dict[str, occlux.Volume]) -> None:
    """The core's writer, zlib-compressed and each grid at the precision its values need
    (`half_grids`), atomic (a temporary file in the folder, renamed when complete): a
    cancelled or failed job never leaves a partial file under the name Blender would load."""
    vdb.parent.mkdir(parents=True, exist_ok=True)
    occlux.write_vdb(vdb, grids, compression="zip", half=half_grids(grids))


def load_work(
    scene: occlux.Scene, source: scenes.VolumeInput, vdb: Path, frame: bool = False
) -> Callable[[JobProgress], Loaded]:
    """Load Volume's work: the volume classified, its `density` and `value` grids in `vdb`;
    with `frame` (the scene's camera asks for it, `scenes.framed_camera`), the camera framing
    its visible content."""

    def work(progress: JobProgress) -> Loaded:
        volume = scenes.load_volume(scene, source, settle=frame)
        classification = scene.classification
        density = classification.extinction(volume)
        write_grids(vdb, {"density": density, "value": volume})
        camera = scene.describe()["camera"] if frame else None
        return Loaded(vdb, source, classification, volume, camera)

    return work


def unclamped(context: bpy.types.Context) -> str:
    """Sets EEVEE's indirect light in volumes unclamped (`eevee.UNCLAMPED`), as a report says
    it ("" when it was)."""
    changed = eevee.change(context.scene, eevee.UNCLAMPED)
    return f"; set {', '.join(changed)} (the world lights volumes in EEVEE)" if changed else ""


class OCCLUX_OT_import_volume(OccluxJob, bpy.types.Operator):
    """Load the volume file, classify it with the preset and add it as a Volume object"""

    bl_idname = "occlux.import_volume"
    bl_label = "Load Volume"
    bl_options = {"REGISTER", "UNDO"}

    def prepare(self, context: bpy.types.Context) -> Callable[[JobProgress], Loaded]:
        settings = context.scene.occlux
        source = scenes.VolumeInput.from_settings(settings)
        self._classified = scenes.classification_section(settings)
        tree = scenes.volume_tree(source, settings)
        if settings.frame_camera:
            tree["camera"] = scenes.framed_camera(context.scene)
        scene = scenes.build(tree)
        vdb = named_vdb(settings, source, "", {})
        return load_work(scene, source, vdb, frame=settings.frame_camera)

    def finish(self, context: bpy.types.Context, result: Loaded) -> str:
        obj = show_volume(context, result, PLAIN, None, None, self._classified)
        told = unclamped(context)
        if result.camera is not None and context.scene.camera is not None:
            scenes.place_camera(context.scene.camera, result.camera)
            told += f"; framed camera '{context.scene.camera.name}' on the visible content"
        return f"loaded {result.source.path.name} as '{obj.name}' ({result.vdb}){told}"


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
        source, target = scenes.panel_dataset(context)
        self._classified = scenes.classification_section(settings)
        active = scenes.volume_object(context)
        # By name: the object may go while the work runs (then the file's object is found).
        self._target = None if target is None else target.name
        self._passed_over = None if active is None or active == target else active.name
        scene = scenes.build(scenes.volume_tree(source, settings))
        if material.ao_shading(settings.ao_shading) is None:  # AO off: Load Volume's grids
            return load_work(scene, source, named_vdb(settings, source, "", {}))
        method, options, device = settings.ao_method, ao_options(settings), settings.device
        vdb = named_vdb(settings, source, "ao", {"ao_method": method, **options})

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
        shading = material.ao_shading(settings.ao_shading)
        grids = PLAIN if shading is None else (*PLAIN, "ao")
        obj = show_volume(context, result, grids, shading, target, self._classified)
        source = result.source.path.name
        if shading is None:
            said = f"AO off: '{obj.name}' shows {source} unshaded, the world lighting every ray"
        else:
            said = f"AO ({ao_label(settings)}) of {source} on '{obj.name}'"
        if self._passed_over is not None:
            said += f" (the panel's Volume; the active '{self._passed_over}' is left as it was)"
        return f"{said} ({result.vdb})"


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
    # What a dataset's object keeps of its classification and values (`transfer.kept`).
    kept: str | None = None


# The grids of Load Volume's VDB, which every VDB of a dataset holds.
PLAIN = ("density", "value")


def show_volume(
    context: bpy.types.Context,
    loaded: Loaded,
    grids: tuple[str, ...],
    ao: str | None,
    target: bpy.types.Object | None,
    classified: dict[str, Any],
) -> bpy.types.Object:
    """The dataset's Volume object (`show`) for a VDB a job wrote, holding `grids`, classified
    by the scene's `classified` classification."""
    return show(context, dataset_shown(loaded, grids, classified), ao, target)


def dataset_shown(loaded: Loaded, grids: tuple[str, ...], classified: dict[str, Any]) -> Shown:
    """What the dataset's object shows of a VDB a job wrote (the add-on's own file) holding
    `grids`, classified by the scene's `classified` classification (which the object keeps,
    with the file's robust window and histogram: `transfer.kept`)."""
    return Shown(
        name=loaded.source.stem,
        vdb=loaded.vdb,
        grids=grids,
        points=loaded.classification.raw_points(loaded.volume),
        box=loaded.volume.bounds,
        mark=SOURCE,
        setting=loaded.source.setting,
        owned=True,
        kept=transfer.kept(loaded.volume, classified),
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
    if shown.kept is not None:
        obj[transfer.CLASSIFIED] = shown.kept
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
