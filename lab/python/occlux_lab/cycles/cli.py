"""The command line, ``python -m occlux_lab.cycles`` (what ``occlux check-cycles`` runs, with every
option below)."""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from pathlib import Path

from occlux._occlux import OccluxError
from occlux.blender.common import DEFAULT_BOUNCES, DEFAULT_SEEDS, ESTIMATORS

from .check import check

EXIT_DISAGREE = 3
"""Exit status of the command line when the check ran and the images disagree (2: it could not
run; 0: they agree)."""


def parser() -> argparse.ArgumentParser:
    """The command line's arguments (``occlux check-cycles`` has the same, with the same
    defaults)."""
    p = argparse.ArgumentParser(
        prog="python -m occlux_lab.cycles",
        description="Render an Occlux scene with Cycles and compare it with Occlux's Monte Carlo "
        "reference, pixel by pixel in units of the combined standard error.",
    )
    p.add_argument("scene", type=Path, help="the scene file (TOML)")
    p.add_argument("--estimator", choices=ESTIMATORS, default="single")
    p.add_argument("--spp", type=int, default=256, help="samples per pixel, for both")
    p.add_argument(
        "--seeds", type=int, default=DEFAULT_SEEDS, help="Cycles renders (spp / seeds samples each)"
    )
    p.add_argument(
        "--bounces", type=int, default=DEFAULT_BOUNCES, help="volume bounces (multiple only)"
    )
    p.add_argument("--g", type=float, default=0.0, help="Henyey-Greenstein asymmetry")
    p.add_argument("--out", type=Path, default=Path("occlux-check"))
    return p


def main(argv: Sequence[str] | None = None) -> int:
    args = parser().parse_args(argv)
    try:
        result = check(
            args.scene, args.estimator, args.spp, args.out, args.seeds, args.bounces, args.g
        )
    except OccluxError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    print(f"{args.scene} {args.estimator}, {args.spp} spp")
    print(f"{'Occlux time':<16} {result.occlux_seconds:.2f} s (reference, volume loaded)")
    print(f"{'Cycles time':<16} {result.cycles.seconds:.2f} s ({len(result.cycles.seeds)} seeds)")
    print(result.report.table())
    for path in result.files:
        print(f"wrote {path}")
    return 0 if result.report.agrees() else EXIT_DISAGREE
