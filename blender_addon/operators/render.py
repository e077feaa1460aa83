"""Method renders: the volume from the active camera by one of the core's rendering methods, into
an EXR for the compositor (layers beauty, depth and the method's factor, premultiplied by
coverage: `occlusion` for DOS, `shadow` for IPSVI).
Directional occlusion shading is lit by the world; IPSVI by the scene's sun and point lamps."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

import bpy
import occlux

from .. import scenes
from .jobs import JobProgress, OccluxJob, output_dir


def render_size(render) -> tuple[int, int]:
    """The render's resolution at its percentage."""
    width = max(1, render.resolution_x * render.resolution_percentage // 100)
    height = max(1, render.resolution_y * render.resolution_percentage // 100)
    return width, height


def dos_section(settings) -> dict[str, Any]:
    """DOS's `render` section from the panel."""
    section = {
        "method": "dos",
        "theta_deg": float(settings.dos_theta_deg),
        "grid": int(settings.dos_grid),
        "distance": settings.dos_distance,
        "sampling": settings.dos_sampling,
    }
    if settings.dos_slice_distance > 0.0:  # else absent: the core's default
        section["slice_distance"] = float(settings.dos_slice_distance)
    return section


def ipsvi_section(settings) -> dict[str, Any]:
    """IPSVI's `render` section from the panel."""
    section = {
        "method": "ipsvi",
        "line_width": int(settings.ipsvi_line_width),
        "g": float(settings.ipsvi_g),
        "scattering": settings.ipsvi_scattering,
    }
    if settings.ipsvi_cache_size > 0:  # else absent: matched to the image and the voxels
        section["cache_size"] = int(settings.ipsvi_cache_size)
    return section


class MethodRender(OccluxJob):
    """A render by the registered method `METHOD`, its `render` section from the subclass's
    `section(settings)`."""

    METHOD = ""

    def prepare(self, context: bpy.types.Context) -> Callable[[JobProgress], tuple[Path, str]]:
        settings = context.scene.occlux
        source = scenes.selected_source(context)
        width, height = render_size(context.scene.render)
        entry = scenes.method(self.METHOD)
        described = scenes.scene_tree(
            context, source, width, height, entry["lights"], render=self.section(settings)
        )
        scene = scenes.build(described.tree)
        self._left_out = described.left_out
        device = settings.device
        exr = output_dir(settings) / f"{source.stem}-{self.METHOD}.exr"
        layers = ", ".join(entry["layers"])

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
        method = self.bl_label.removeprefix("Render ")
        message = f"{method} render written to {exr} (layers {layers})"
        if self._left_out:
            self.report({"WARNING"}, self._left_out)
            message += f"; {self._left_out}"
        return message


class OCCLUX_OT_render_dos(MethodRender, bpy.types.Operator):
    """Render the volume from the active camera with directional occlusion shading (the
    world's ambient light) and write the EXR (layers beauty, depth, occlusion) for
    compositing"""

    bl_idname = "occlux.render_dos"
    bl_label = "Render DOS"
    bl_options = {"REGISTER"}
    METHOD = "dos"
    section = staticmethod(dos_section)


class OCCLUX_OT_render_ipsvi(MethodRender, bpy.types.Operator):
    """Render the volume from the active camera with image plane sweep volume illumination
    (single scattering with shadows from the scene's sun and point lamps) and write the EXR
    (layers beauty, depth, shadow) for compositing"""

    bl_idname = "occlux.render_ipsvi"
    bl_label = "Render IPSVI"
    bl_options = {"REGISTER"}
    METHOD = "ipsvi"
    section = staticmethod(ipsvi_section)


CLASSES = (OCCLUX_OT_render_dos, OCCLUX_OT_render_ipsvi)
