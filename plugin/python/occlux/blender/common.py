"""What every part of :mod:`occlux.blender` shares: its error, the estimators Cycles can
reproduce, and the seeds and render count of a comparison."""

from __future__ import annotations

from occlux._occlux import OccluxError

ESTIMATORS = ("ambient", "single", "multiple")
"""The Occlux estimators that Cycles can reproduce (the DOS cone phase function has no Cycles
counterpart)."""

DEFAULT_SEEDS = 32
"""Cycles renders per comparison: the per-pixel standard error is their spread, so it needs a
dozen or more (with K renders the z scores follow Student's t with about K - 1 degrees of freedom
where Cycles' noise dominates). ``occlux check-cycles`` has the same default
(lab/src/cycles.rs)."""

DEFAULT_BOUNCES = 8
"""Volume bounces of the "multiple" estimator unless told otherwise (as ``occlux reference``)."""

OCCLUX_SEED = 1
"""The seed the harness gives ``occlux.reference``; no Cycles render uses it."""

CYCLES_FIRST_SEED = 1000
"""Cycles renders use seeds CYCLES_FIRST_SEED, CYCLES_FIRST_SEED + 1, ..."""

Rgb = tuple[float, float, float]


class HarnessError(OccluxError):
    """A scene that cannot be mapped onto Cycles, or a step of the cross-check that failed; the
    message names the file and the problem."""


def check_estimator(estimator: str) -> None:
    """Raises HarnessError unless Cycles can reproduce ``estimator``."""
    if estimator not in ESTIMATORS:
        raise HarnessError(f"estimator '{estimator}': Cycles can reproduce {', '.join(ESTIMATORS)}")


def effective_options(estimator: str, bounces: int, g: float) -> tuple[int, float]:
    """The bounces and g an estimator uses: bounces only for "multiple", and "ambient" is
    isotropic."""
    if estimator != "multiple":
        bounces = 0
    if estimator == "ambient":
        g = 0.0
    return bounces, g
