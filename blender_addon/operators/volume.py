"""Volume import and ambient occlusion: load and classify the volume file into the scene as a
Volume object, and compute its VAO volume into an `ao` grid that shades its material."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import bpy
import occlux

from .. import nodes, scenes
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
        obj = add_volume_object(context, result, ao=None)
        return f"loaded {result.source.path.name} as '{obj.name}' ({result.vdb})"


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
    if settings.ao_method == "sweep-physical":
        return {}
    return {"radius": settings.ao_radius}


def ao_label(settings: bpy.types.PropertyGroup) -> str:
    """The AO method as the status line says it."""
    if settings.ao_method.startswith("sweep"):
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
        source = scenes.VolumeInput.from_settings(settings)
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
        obj = add_volume_object(context, result, ao=settings.ao_shading)
        source = result.source.path.name
        return f"AO ({ao_label(settings)}) of {source} as '{obj.name}' ({result.vdb})"


def add_volume_object(context: bpy.types.Context, loaded: Loaded, ao: str | None):
    """A Volume object for the VDB with the Occlux material; the previous one of that name is
    replaced. If Blender cannot read the file, nothing is added (and the file is removed)."""
    name = loaded.vdb.stem
    data = bpy.data.volumes.new(name)
    data.filepath = str(loaded.vdb)
    if not data.grids.load():
        error = data.grids.error_message
        bpy.data.volumes.remove(data)
        loaded.vdb.unlink(missing_ok=True)
        raise OSError(f"Blender cannot read {loaded.vdb}: {error}")
    old = bpy.data.objects.get(name)
    if old is not None:
        bpy.data.objects.remove(old)
    obj = bpy.data.objects.new(name, data)
    context.scene.collection.objects.link(obj)
    material = nodes.volume_material(
        f"Occlux {name}",
        loaded.classification.points,
        loaded.volume.value_range,
        loaded.classification.units,
        ao,
        context.scene.occlux.ao_factor,
    )
    data.materials.append(material)
    obj["occlux_source"] = loaded.source.setting
    return obj


CLASSES = (OCCLUX_OT_import_volume, OCCLUX_OT_compute_ao)
