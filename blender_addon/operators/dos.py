"""Directional occlusion shading: render the volume from the active camera, lit by the world,
into an EXR (layers beauty, depth, dos, occlusion) for the compositor."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

import bpy
import occlux

from .. import scenes
from .jobs import JobProgress, OccluxJob, output_dir

METHOD = "dos"


def render_section(settings) -> dict[str, Any]:
    """The scene's `render` section: the method and the panel's parameters."""
    section = {
        "method": METHOD,
        "theta_deg": float(settings.dos_theta_deg),
        "grid": int(settings.dos_grid),
        "distance": settings.dos_distance,
    }
    if settings.dos_slice_distance > 0.0:  # else absent: the core's default
        section["slice_distance"] = float(settings.dos_slice_distance)
    return section


def render_size(render) -> tuple[int, int]:
    """The render's resolution at its percentage."""
    width = max(1, render.resolution_x * render.resolution_percentage // 100)
    height = max(1, render.resolution_y * render.resolution_percentage // 100)
    return width, height


class OCCLUX_OT_render_dos(OccluxJob, bpy.types.Operator):
    """Render the volume from the active camera with directional occlusion shading (the
    world's ambient light) and write the EXR (layers beauty, depth, dos, occlusion) for
    compositing"""

    bl_idname = "occlux.render_dos"
    bl_label = "Render DOS"
    bl_options = {"REGISTER"}

    def prepare(self, context: bpy.types.Context) -> Callable[[JobProgress], Path]:
        settings = context.scene.occlux
        source = scenes.VolumeInput.from_settings(settings)
        width, height = render_size(context.scene.render)
        lights = scenes.method(METHOD)["lights"]  # what DOS renders: the ambient light
        tree = scenes.scene_tree(
            context, source, width, height, lights, render=render_section(settings)
        )
        scene = scenes.build(tree)
        device = settings.device
        exr = output_dir(settings) / f"{source.stem}-dos.exr"
        layers = ", ".join(scenes.method(METHOD)["layers"])

        def work(progress: JobProgress) -> tuple[Path, str]:
            volume = scenes.load_volume(scene, source)
            result = occlux.render(scene, volume=volume, device=device, progress=progress)
            exr.parent.mkdir(parents=True, exist_ok=True)
            occlux.write_exr(exr, result, scene)  # atomic: a temporary file, then renamed
            return exr, layers

        return work

    def finish(self, context: bpy.types.Context, result: tuple[Path, str]) -> str:
        exr, layers = result
        context.scene.occlux.last_exr = str(exr)
        return f"DOS render written to {exr} (layers {layers})"


CLASSES = (OCCLUX_OT_render_dos,)
