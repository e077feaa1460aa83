"""The check against Cycles: Occlux's Monte Carlo reference and Cycles (through the harness
`occlux.cycles`) render the same volume, camera and lights; the add-on compares them pixel by
pixel, shows the figures and loads the error map."""

from __future__ import annotations

import math
import shutil
import tempfile
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import bpy
import numpy as np
import occlux

from .. import scenes
from .jobs import JobProgress, OccluxJob, report_dir


@dataclass(frozen=True)
class Reference:
    """An Occlux reference, the scene it rendered and the VDB of its volume (in a temporary
    folder)."""

    folder: Path
    stem: str
    scene: Any
    vdb: Path
    result: Any
    seconds: float


def image_size(render, longest: int) -> tuple[int, int]:
    """`longest` pixels along the render's longer side, its aspect kept."""
    w, h = render.resolution_x * render.pixel_aspect_x, render.resolution_y * render.pixel_aspect_y
    scale = longest / max(w, h)
    return max(1, round(w * scale)), max(1, round(h * scale))


class OCCLUX_OT_check_cycles(OccluxJob, bpy.types.Operator):
    """Render the volume with Occlux's Monte Carlo reference and with Cycles (same camera and
    lights), compare them pixel by pixel, and load the error map"""

    bl_idname = "occlux.check_cycles"
    bl_label = "Check Against Cycles"
    bl_options = {"REGISTER"}

    def prepare(self, context: bpy.types.Context) -> Callable[[JobProgress], Reference]:
        import occlux.cycles as oc

        settings = context.scene.occlux
        source = scenes.VolumeInput.from_settings(settings)
        width, height = image_size(context.scene.render, settings.check_size)
        scene = scenes.build(scenes.scene_tree(context, source, width, height))
        estimator, spp = settings.check_estimator, settings.check_spp

        def work(progress: JobProgress) -> Reference:
            folder = Path(tempfile.mkdtemp(prefix="occlux-check-"))
            try:
                volume = scenes.load_volume(scene, source)
                vdb = folder / f"{source.stem}.vdb"
                occlux.write_vdb(vdb, {"value": volume})  # what the harness maps onto Cycles
                started = time.perf_counter()
                result = occlux.reference(
                    scene, estimator=estimator, spp=spp, seed=oc.OCCLUX_SEED, volume=volume,
                    progress=progress,
                )  # fmt: skip
            except BaseException:
                shutil.rmtree(folder)
                raise
            seconds = time.perf_counter() - started
            return Reference(folder, source.stem, scene, vdb, result, seconds)

        return work

    def finish(self, context: bpy.types.Context, ref: Reference) -> str:
        # Cycles renders through bpy, which only the main thread may call: this part blocks.
        import occlux.cycles as oc

        settings = context.scene.occlux
        estimator, spp, seeds = settings.check_estimator, settings.check_spp, settings.check_seeds
        try:
            scene = oc.build_scene(ref.scene, ref.vdb, estimator)
            cycles = oc.render_scene(scene, spp, seeds)
        finally:
            oc._remove_previous(bpy)  # the harness's scene, objects and world
            shutil.rmtree(ref.folder)
        occlux_image = oc.OccluxImage(
            np.asarray(ref.result.mean, np.float64),
            np.asarray(ref.result.stderr, np.float64),
            {"spp": ref.result.spp},
            {},
        )
        report = oc.compare(occlux_image, cycles.mean, cycles.stderr)
        if not (math.isfinite(report.rmse) and math.isfinite(report.rmse_over_noise)):
            raise ValueError(f"the comparison is not finite:\n{report.table()}")
        stem = f"{ref.stem}-{estimator}"
        extra = {
            "source": settings.volume_path,
            "estimator": estimator,
            "spp": spp,
            "occlux_seconds": ref.seconds,
            "cycles_seconds": cycles.seconds,
        }
        _, png, js = oc.write_outputs(
            report_dir(settings), stem, occlux_image, cycles, report, extra
        )
        image = bpy.data.images.load(str(png), check_existing=True)
        image.reload()  # a previous check's map of the same name
        settings.check_rmse = report.rmse
        settings.check_rmse_over_noise = report.rmse_over_noise
        settings.check_rms_z = report.rms_z
        settings.check_agrees = report.agrees()
        settings.check_report = str(js)
        verdict = "agree within noise" if report.agrees() else "DISAGREE"
        return (
            f"Occlux vs Cycles ({estimator}, {spp} spp): RMSE {report.rmse:.4g}, "
            f"{report.rmse_over_noise:.3f} x the noise, {verdict}; error map '{image.name}'"
        )


CLASSES = (OCCLUX_OT_check_cycles,)
