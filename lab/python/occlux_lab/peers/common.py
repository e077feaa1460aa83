"""What every peer's curve module shares: its command line and its JSON."""

from __future__ import annotations

import argparse
import json
import os
from collections.abc import Sequence
from pathlib import Path
from typing import Any, NotRequired, TypedDict

ESTIMATORS = ("ambient", "single", "multiple")
"""The lightings of ``occlux chart`` by the estimator of their truth."""


class CurvePoint(TypedDict):
    """One render of a peer: its setting in words, its wall time, its image, for a path tracer
    its samples per pixel, and for a point off the peer's quality axis the series it belongs to
    (the chart draws it apart, as "PEER, SERIES": VTK without shadows)."""

    setting: str
    seconds: float
    exr: str
    spp: NotRequired[int]
    series: NotRequired[str]


def parser(prog: str, description: str) -> argparse.ArgumentParser:
    """The command line every peer takes (see the package docs)."""
    p = argparse.ArgumentParser(prog=prog, description=description)
    p.add_argument("scene", type=Path, help="the scene file (TOML)")
    p.add_argument("--estimator", choices=ESTIMATORS, default="single")
    p.add_argument("--bounces", type=int, default=8, help="volume bounces of 'multiple'")
    p.add_argument("--g", type=float, default=0.0, help="Henyey-Greenstein asymmetry")
    p.add_argument("--out", type=Path, required=True)
    return p


def curve_path(out: str | os.PathLike[str], peer: str, estimator: str) -> Path:
    """Where a peer's curve JSON goes: ``OUT/PEER-ESTIMATOR-curve.json``."""
    return Path(out) / f"{peer}-{estimator}-curve.json"


def write_curve(
    out: str | os.PathLike[str],
    peer: str,
    estimator: str,
    scene: str | os.PathLike[str],
    points: Sequence[CurvePoint],
    timing: str,
    extra: dict[str, Any] | None = None,
) -> dict[str, Any]:
    """Writes ``{"peer", "scene", "estimator", "timing", "points": [{"setting", "seconds",
    "exr", "spp"?}], ...extra}`` atomically to :func:`curve_path` and returns it. ``timing``
    says what the seconds include (the chart shows it)."""
    report: dict[str, Any] = {
        "peer": peer,
        "scene": str(scene),
        "estimator": estimator,
        "timing": timing,
        "points": list(points),
        **(extra or {}),
    }
    path = curve_path(out, peer, estimator)
    partial = path.with_suffix(".json.partial")
    partial.write_text(json.dumps(report, indent=2))
    partial.replace(path)
    return report
