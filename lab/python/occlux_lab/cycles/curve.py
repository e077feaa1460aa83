"""Cycles' time against its samples per pixel, for ``occlux chart``: one render of the scene at
each sample count, each timed from scratch (the volume build included, as a user pays it), the
images written as EXR for the chart to measure, and their times as JSON.

``python -m occlux_lab.cycles.curve SCENE --estimator single --spp 1,4,16 --out DIR`` writes
DIR/cycles-ESTIMATOR-SPPspp.exr per sample count and DIR/cycles-ESTIMATOR-curve.json, the curve
of every peer of the chart (:mod:`occlux_lab.peers`): ``{"peer", "scene", "estimator", "timing",
"points": [{"setting", "seconds", "exr", "spp"}], "bounces", "g"}``. (Not imported by
``occlux_lab.cycles`` itself, so that ``-m`` runs it cleanly.)
"""

from __future__ import annotations

import argparse
import os
import sys
import warnings
from collections.abc import Sequence
from pathlib import Path

from occlux._occlux import OccluxError, Scene, export
from occlux.blender.common import (
    CYCLES_FIRST_SEED,
    DEFAULT_BOUNCES,
    ESTIMATORS,
    HarnessError,
    effective_options,
)
from occlux.blender.cycles import SEQUENCE_LENGTH, build_scene, render_still

from occlux_lab.peers.common import write_curve


def render_curve(
    scene_path: str | os.PathLike[str],
    estimator: str,
    spps: Sequence[int],
    out: str | os.PathLike[str],
    bounces: int = DEFAULT_BOUNCES,
    g: float = 0.0,
) -> dict:
    """Renders the scene with Cycles once per sample count in ``spps`` and writes the images and
    the JSON into ``out`` (see the module docs); returns what the JSON holds. Each render draws
    its samples from one SEQUENCE_LENGTH-sample sequence (see :mod:`occlux.blender.cycles`) and
    keeps no render data from the one before, so its time includes building the volume."""
    if not spps or any(s < 1 for s in spps):
        raise HarnessError(f"sample counts must be at least 1, got {list(spps)}")
    scene_path, out = Path(scene_path), Path(out)
    out.mkdir(parents=True, exist_ok=True)
    bounces, g = effective_options(estimator, bounces, g)
    scene = Scene.load(scene_path)
    volume, _ = scene.settle()
    with warnings.catch_warnings():
        # "auto" falls back to the CPU with a RuntimeWarning; only the grids are wanted here.
        warnings.simplefilter("ignore", RuntimeWarning)
        export(scene, out, stem=scene_path.stem, volume=volume)
    blender_scene = build_scene(
        scene, out / f"{scene_path.stem}.vdb", estimator, bounces, g, volume=volume
    )
    c = blender_scene.cycles
    c.samples = max(SEQUENCE_LENGTH, max(spps))
    c.use_sample_subset = True
    c.sample_offset = 0
    c.seed = CYCLES_FIRST_SEED
    points = []
    for spp in spps:
        exr = out / f"cycles-{estimator}-{spp}spp.exr"
        c.sample_subset_length = spp
        seconds = render_still(blender_scene, exr, f"Cycles render at {spp} spp")
        points.append({"setting": f"{spp} spp", "seconds": seconds, "exr": str(exr), "spp": spp})
    timing = "each render from scratch in one Blender session: the volume build included"
    extra = {"bounces": bounces, "g": g}
    return write_curve(out, "cycles", estimator, scene_path, points, timing, extra)


def main(argv: Sequence[str] | None = None) -> int:
    p = argparse.ArgumentParser(
        prog="python -m occlux_lab.cycles.curve",
        description="Time Cycles at several sample counts on an Occlux scene (for occlux chart).",
    )
    p.add_argument("scene", type=Path, help="the scene file (TOML)")
    p.add_argument("--estimator", choices=ESTIMATORS, default="single")
    p.add_argument(
        "--spp",
        type=lambda text: [int(s) for s in text.split(",")],
        default=[1, 4, 16],
        help="sample counts, comma-separated",
    )
    p.add_argument("--bounces", type=int, default=DEFAULT_BOUNCES)
    p.add_argument("--g", type=float, default=0.0)
    p.add_argument("--out", type=Path, default=Path("occlux-cycles-curve"))
    args = p.parse_args(argv)
    try:
        report = render_curve(args.scene, args.estimator, args.spp, args.out, args.bounces, args.g)
    except OccluxError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    for point in report["points"]:
        print(f"Cycles {point['spp']:>5} spp {point['seconds']:.2f} s -> {point['exr']}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
