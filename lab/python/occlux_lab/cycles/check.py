"""The whole cross-check, in one process: Occlux's export (the VDB that Blender reads) and Monte
Carlo reference through the ``occlux`` package, Cycles through bpy, and the comparison."""

from __future__ import annotations

import os
import time
import warnings
from dataclasses import dataclass
from pathlib import Path

from occlux._occlux import Scene, export, reference, write_reference
from occlux.blender.common import (
    DEFAULT_BOUNCES,
    DEFAULT_SEEDS,
    OCCLUX_SEED,
    check_estimator,
    effective_options,
)
from occlux.blender.cycles import CyclesImage, build_scene, check_camera, render_scene
from occlux.blender.images import read_reference, write_outputs
from occlux.blender.stats import Report, compare


@dataclass
class Check:
    """A check's report, the wall time of Occlux's reference (the sampling, with the volume
    already loaded), the Cycles estimate and the files written."""

    report: Report
    occlux_seconds: float
    cycles: CyclesImage
    files: list[Path]


def check(
    scene_path: str | os.PathLike[str],
    estimator: str,
    spp: int,
    out: str | os.PathLike[str],
    seeds: int = DEFAULT_SEEDS,
    bounces: int = DEFAULT_BOUNCES,
    g: float = 0.0,
) -> Check:
    """The whole cross-check of a scene file, written into ``out``: what ``occlux export``
    writes (OUT/STEM.exr, .png, .vdb, .usda), ``occlux reference``'s image
    (OUT/STEM-ESTIMATOR.exr, .png), Cycles' estimate, the error map and the report
    (:func:`occlux.blender.images.write_outputs`). Occlux runs in this process
    (``occlux.export`` and ``occlux.reference``, on one loaded volume); nothing else is
    started."""
    scene_path, out = Path(scene_path), Path(out)
    check_estimator(estimator)
    bounces, g = effective_options(estimator, bounces, g)
    stem = scene_path.stem
    scene = Scene.load(scene_path)
    volume, _ = scene.settle()
    with warnings.catch_warnings():
        # "auto" falls back to the CPU with a RuntimeWarning; the render is not what is checked.
        warnings.simplefilter("ignore", RuntimeWarning)
        export(scene, out, stem=stem, volume=volume)
    started = time.perf_counter()
    result = reference(
        scene, estimator=estimator, spp=spp, seed=OCCLUX_SEED, bounces=bounces, g=g,
        volume=volume,
    )  # fmt: skip
    occlux_seconds = time.perf_counter() - started
    name = f"{stem}-{estimator}"
    write_reference(
        out, result, scene, stem=name, estimator=estimator, seed=OCCLUX_SEED, bounces=bounces,
        g=g,
    )  # fmt: skip
    occlux = read_reference(out / f"{name}.exr")
    vdb = out / f"{stem}.vdb"
    blender_scene = build_scene(scene, vdb, estimator, bounces, g, volume=volume)
    check_camera(blender_scene, occlux.camera)
    cycles = render_scene(blender_scene, spp, seeds)
    report = compare(occlux, cycles.mean, cycles.stderr)
    extra = {
        "scene": str(scene_path),
        "estimator": estimator,
        "spp": spp,
        "bounces": bounces,
        "g": g,
        "occlux_seconds": occlux_seconds,
        "cycles_seconds": cycles.seconds,
    }
    files = write_outputs(out, name, occlux, cycles, report, extra)
    return Check(report, occlux_seconds, cycles, files)
