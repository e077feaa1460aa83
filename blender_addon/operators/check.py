"""The check against Cycles, of the figure or of the reference:
- The figure: the chosen Occlux method (AO-shaded, DOS, IPSVI, with the panel's settings)
  against Cycles' path-traced truth of its lighting (the world for AO and DOS, suns and point lamps
  for IPSVI): docs/architecture.md#error-measure's relative RMSE and bias over the volume's pixels,
  both times, and a map of the difference with a colour key. Cycles renders the user's scene as it
  stands (the dataset's Volume object with its material, the camera, the world, the lamps; see
  `truth`); without an Occlux Volume object in the scene, the Cycles mapping (`occlux.blender`) maps
  the panel's classification of the file onto Cycles (docs/cycles-mapping.md).
- The reference: Occlux's Monte Carlo reference against Cycles' rendering of the Cycles
  mapping of the same scene, within noise (z scores).
Occlux's half runs on the job's thread; Cycles' renders (bpy: the main thread) are the job's
steps, one render each, with progress and ESC between them."""

from __future__ import annotations

import json
import math
import shutil
import tempfile
import time
from collections.abc import Callable, Generator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import bpy
import numpy as np
import occlux

from .. import scenes, truth
from . import check_baked
from .jobs import JobProgress, OccluxJob, Step, Steps, report_dir
from .render import dos_section, ipsvi_section
from .volume import ao_section


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


def occlux_side(
    scene: Any, source: scenes.VolumeInput, compute: Callable[[Any], Any]
) -> tuple[Path, Path, Any, Any, float]:
    """Occlux's half of a check: loads the scene's volume, writes its `value` grid (what the
    Cycles mapping renders) into a new temporary folder, and runs `compute(volume)`, timed.
    Returns (folder, VDB, volume, result, seconds); on any failure the folder is removed."""
    folder = Path(tempfile.mkdtemp(prefix="occlux-check-"))
    try:
        volume = scenes.load_volume(scene, source)
        vdb = folder / f"{source.stem}.vdb"
        occlux.write_vdb(vdb, {"value": volume})
        started = time.perf_counter()
        result = compute(volume)
    except BaseException:
        shutil.rmtree(folder)
        raise
    return folder, vdb, volume, result, time.perf_counter() - started


@dataclass(frozen=True)
class Figure:
    """An Occlux method's render, the scene it rendered, and what Cycles' truth of it needs: the
    VDB of its volume (in a temporary folder), the estimator of its lighting, its bounces and
    phase."""

    folder: Path
    stem: str
    method: str
    scene: Any
    tree: dict
    vdb: Path
    volume: Any
    image: np.ndarray
    seconds: float
    estimator: str
    bounces: int
    g: float
    kinds: tuple[str, ...]
    size: tuple[int, int]
    volume_object: str | None


# Each checked method: its `render` section from the panel and the lights it renders.
FIGURE_METHODS = {
    "ao": (ao_section, (scenes.WORLD,)),
    "dos": (dos_section, (scenes.WORLD,)),
    "ipsvi": (ipsvi_section, (scenes.SUN, scenes.POINT)),
}
# Volume bounces of Cycles' truth for IPSVI's multiple scattering (its references' count).
MULTIPLE_BOUNCES = 8
RENDERS = "Cycles render"


def cycles_renders(scene: Any, spp: int, seeds: int) -> Generator[Step, None, Any]:
    """Cycles' renders of a built scene (`occlux.blender.render_seeds`) as a job's steps, one
    render each; returns the CyclesImage."""
    import occlux.blender as ob

    renders = ob.render_seeds(scene, spp, seeds)
    yield Step(RENDERS, 0, seeds)  # the status says what comes before the first render
    try:
        while True:
            done = next(renders)
            yield Step(RENDERS, done.done, done.total)
    except StopIteration as end:
        return end.value
    finally:
        renders.close()


def write_figure_check(
    settings,
    stem: str,
    checked: str,
    image: np.ndarray,
    cycles: Any,
    background: float,
    fields: dict,
) -> tuple[dict, str, float]:
    """The figures of a checked image against Cycles' truth (docs/architecture.md#error-measure:
    relative RMSE and bias over the volume's pixels), written beside the .blend as STEM-report.json
    (`fields` and the figures), STEM.exr (the image as layer `checked`, Cycles' mean and standard
    error) and STEM-errormap.png (loaded as a Blender image), and shown in the panel. Returns
    the figures, the error map's image name and its colour key's range."""
    figures = occlux.image_error(image, cycles.mean, background, cycles.stderr)
    out = report_dir(settings)
    out.mkdir(parents=True, exist_ok=True)
    error_map = out / f"{stem}-errormap.png"
    key = occlux.write_error_map(error_map, image, cycles.mean, background)
    layers = {checked: image, "cycles": cycles.mean, "cycles_stderr": cycles.stderr}
    occlux.write_exr_layers(out / f"{stem}.exr", layers, float32=True)
    report = {
        **fields,
        "size": list(image.shape[1::-1]),
        "cycles_spp": settings.check_spp,
        "cycles_seeds": settings.check_seeds,
        **figures,
        "cycles_seconds": cycles.seconds,
        "error_map_range": key,
    }
    report_path = out / f"{stem}-report.json"
    occlux.write_text(report_path, json.dumps(report, indent=2) + "\n")
    map_image = bpy.data.images.load(str(error_map), check_existing=True)
    map_image.reload()  # a previous check's map of the same name
    settings.check_rel_rmse = figures["rel_rmse"]
    settings.check_bias = figures["bias"]
    settings.check_cycles_seconds = cycles.seconds
    settings.check_report = str(report_path)
    return figures, map_image.name, key


def truth_of(method: str, settings) -> tuple[str, int, float]:
    """Cycles' estimator, volume bounces and phase asymmetry for the truth of `method`'s
    lighting: the world scattered once for AO and DOS; IPSVI's lamps scattered once, or
    MULTIPLE_BOUNCES times for its multiple-scattering term, with its anisotropy."""
    if method != "ipsvi":
        return "ambient", 0, 0.0
    if settings.ipsvi_scattering in ("multiple", "transport"):
        return "multiple", MULTIPLE_BOUNCES, settings.ipsvi_g
    return "single", 0, settings.ipsvi_g


class OCCLUX_OT_check_cycles(OccluxJob, bpy.types.Operator):
    """Check the figure (the chosen Occlux method against Cycles' path-traced truth of the same
    scene: relative RMSE, bias, times, error map) or validate the reference (Occlux's Monte
    Carlo reference against Cycles, within noise)"""

    bl_idname = "occlux.check_cycles"
    bl_label = "Check Against Cycles"
    bl_options = {"REGISTER"}

    def prepare(self, context: bpy.types.Context) -> Callable[[JobProgress], Any]:
        subject = context.scene.occlux.check_subject
        self._left_out = ""
        if subject == "FIGURE":
            return self.prepare_figure(context)
        if subject == "BAKED":
            size = image_size(context.scene.render, context.scene.occlux.check_size)
            return check_baked.prepare(context, size)
        return self.prepare_reference(context)

    def finish_steps(self, context: bpy.types.Context, result: Any) -> Steps:
        if isinstance(result, Figure):
            message = yield from self.finish_figure(context, result)
        elif isinstance(result, check_baked.BakedCheck):
            message = yield from self.finish_baked(context, result)
        else:
            message = yield from self.finish_reference(context, result)
        return f"{message}; {self._left_out}" if self._left_out else message

    def prepare_figure(self, context: bpy.types.Context) -> Callable[[JobProgress], Figure]:
        settings = context.scene.occlux
        method = settings.check_method
        section, kinds = FIGURE_METHODS[method]
        source = scenes.selected_source(context)
        width, height = image_size(context.scene.render, settings.check_size)
        described = scenes.scene_tree(
            context, source, width, height, kinds, render=section(settings)
        )
        scene = scenes.build(described.tree)
        self._left_out = described.left_out
        estimator, bounces, g = truth_of(method, settings)
        device = settings.device
        shown = scenes.dataset_object(context, source)
        shown_name = None if shown is None else shown.name  # the object may go meanwhile

        def work(progress: JobProgress) -> Figure:
            def compute(volume):
                return occlux.render(scene, volume=volume, device=device, progress=progress)

            folder, vdb, volume, result, seconds = occlux_side(scene, source, compute)
            image = np.asarray(result.beauty)
            return Figure(
                folder, source.stem, method, scene, described.tree, vdb, volume, image,
                seconds, estimator, bounces, g, kinds, (width, height), shown_name,
            )  # fmt: skip

        return work

    def finish_figure(self, context: bpy.types.Context, figure: Figure) -> Steps:
        import occlux.blender as ob

        settings = context.scene.occlux
        spp, seeds = settings.check_spp, settings.check_seeds
        try:
            built = self.truth_scene(context, figure)
            ob.check_camera(built.scene, figure.scene.describe()["camera"])
            cycles = yield from cycles_renders(built.scene, spp, seeds)
        finally:
            ob.remove_built()  # the mapping's scene, objects, materials and world
            shutil.rmtree(figure.folder)
        notes = "; ".join(built.notes)
        self._left_out = "; ".join(n for n in (self._left_out, notes) if n)
        background = float(np.mean(figure.tree["background"]))
        fields = {
            "source": str(figure.tree["volume"]["path"]),
            "method": figure.tree["render"],
            "truth": {"estimator": figure.estimator, "bounces": figure.bounces, "g": figure.g},
            "cycles_scene": built.holds,
            "occlux_seconds": figure.seconds,
            "left_out": self._left_out,
        }
        stem = f"{figure.stem}-{figure.method}-figure"
        figures, map_name, key = write_figure_check(
            settings, stem, "occlux", figure.image, cycles, background, fields
        )
        settings.check_checked = "Occlux"
        settings.check_occlux_seconds = figure.seconds
        return (
            f"{figure.method} vs Cycles ({figure.estimator}, {spp} spp): relative RMSE "
            f"{figures['rel_rmse']:.3f}, bias {figures['bias']:+.1%} over {figures['pixels']} "
            f"pixels (Cycles' noise {figures['noise']:.3f}); Occlux {figure.seconds:.2f} s, "
            f"Cycles {cycles.seconds:.1f} s; error map '{map_name}' (+-{key:.0%})"
        )

    def finish_baked(self, context: bpy.types.Context, check: check_baked.BakedCheck) -> Steps:
        settings = context.scene.occlux
        engine, samples = settings.check_engine, settings.check_engine_samples
        image, seconds, built, cycles = yield from check_baked.finish(
            context, check, cycles_renders
        )
        self._left_out = "; ".join(built.notes)
        fields = {
            "source": settings.volume_path,
            "engine": engine,
            "engine_samples": samples,
            "engine_seconds": seconds,
            "background": check.background,
            "truth": {
                "bounces": check.bounces,
                "g": check.g,
            },
            "cycles_scene": built.holds,
            "left_out": self._left_out,
        }
        stem = f"{check.stem}-{engine.lower()}-baked"
        figures, map_name, key = write_figure_check(
            settings, stem, "baked", image, cycles, check.background, fields
        )
        settings.check_checked = f"{engine.capitalize()} {samples} spp"
        settings.check_occlux_seconds = seconds
        return (
            f"baked scene in {engine} ({samples} spp) vs Cycles' truth ({settings.check_spp} "
            f"spp): relative RMSE {figures['rel_rmse']:.3f}, bias {figures['bias']:+.1%} over "
            f"{figures['pixels']} pixels (Cycles' noise {figures['noise']:.3f}); {engine} "
            f"{seconds:.2f} s, Cycles {cycles.seconds:.1f} s; error map '{map_name}' "
            f"(+-{key:.0%})"
        )

    def truth_scene(self, context: bpy.types.Context, figure: Figure) -> truth.Truth:
        """Cycles' scene of the figure: the user's own (`truth.figure_truth`) when an Occlux
        Volume object shows the dataset, else the Cycles mapping of the file."""
        import occlux.blender as ob

        obj = bpy.data.objects.get(figure.volume_object) if figure.volume_object else None
        if obj is not None:
            return truth.figure_truth(
                context, obj, figure.kinds, figure.bounces, figure.g, figure.size
            )
        built = ob.build_scene(
            figure.scene, figure.vdb, figure.estimator, figure.bounces, figure.g,
            volume=figure.volume,
        )  # fmt: skip
        note = (
            "no Occlux volume object shows the file: Cycles rendered the panel's "
            "classification of it (Load Volume adds one)"
        )
        return truth.Truth(built, {"harness": "the panel's classification of the file"}, [note])

    def prepare_reference(self, context: bpy.types.Context) -> Callable[[JobProgress], Reference]:
        import occlux.blender as ob

        settings = context.scene.occlux
        source = scenes.selected_source(context)
        width, height = image_size(context.scene.render, settings.check_size)
        described = scenes.scene_tree(context, source, width, height)
        scene = scenes.build(described.tree)
        self._left_out = described.left_out
        estimator, spp = settings.check_estimator, settings.check_spp

        def work(progress: JobProgress) -> Reference:
            def compute(volume):
                return occlux.reference(
                    scene, estimator=estimator, spp=spp, seed=ob.OCCLUX_SEED, volume=volume,
                    progress=progress,
                )  # fmt: skip

            folder, vdb, _, result, seconds = occlux_side(scene, source, compute)
            return Reference(folder, source.stem, scene, vdb, result, seconds)

        return work

    def finish_reference(self, context: bpy.types.Context, ref: Reference) -> Steps:
        import occlux.blender as ob

        settings = context.scene.occlux
        estimator, spp, seeds = settings.check_estimator, settings.check_spp, settings.check_seeds
        try:
            scene = ob.build_scene(ref.scene, ref.vdb, estimator)
            cycles = yield from cycles_renders(scene, spp, seeds)
        finally:
            ob.remove_built()  # the mapping's scene, objects and world
            shutil.rmtree(ref.folder)
        occlux_image = ob.OccluxImage(
            np.asarray(ref.result.mean, np.float64),
            np.asarray(ref.result.stderr, np.float64),
            {"spp": ref.result.spp},
            {},
        )
        report = ob.compare(occlux_image, cycles.mean, cycles.stderr)
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
        _, png, js = ob.write_outputs(
            report_dir(settings), stem, occlux_image, cycles, report, extra
        )
        image = bpy.data.images.load(str(png), check_existing=True)
        image.reload()  # a previous check's map of the same name
        settings.check_rmse = report.rmse
        settings.check_rmse_over_noise = report.rmse_over_noise
        settings.check_z_scale = report.z_scale
        settings.check_agrees = report.agrees()
        settings.check_report = str(js)
        verdict = "agree within noise" if report.agrees() else "DISAGREE"
        return (
            f"Occlux vs Cycles ({estimator}, {spp} spp): RMSE {report.rmse:.4g}, "
            f"{report.rmse_over_noise:.3f} x the noise, {verdict}; error map '{image.name}'"
        )


CLASSES = (OCCLUX_OT_check_cycles,)
