"""The cross-check of Occlux's Monte Carlo references against Blender's Cycles, as a measurement:
Occlux's export and reference, in this process, and Cycles' renders of the same scene through
:mod:`occlux.blender` (the mapping, the renders at many seeds, the z scores), compared pixel by
pixel in units of the combined standard error and written out as a report and an error map.

Its parts: :mod:`.check` (the whole check), :mod:`.cli` (the command line) and :mod:`.curve`
(Cycles' time against its samples per pixel, for ``occlux chart``; run on its own).

From a shell (what ``occlux check-cycles`` runs, with lab/python on PYTHONPATH)::

    python -m occlux_lab.cycles examples/engine.toml --estimator single --spp 256 --out check/

From Python::

    from occlux_lab.cycles import check

    result = check("examples/engine.toml", "single", spp=256, out="check/")
    print(result.report.table())
"""

from occlux_lab.cycles.check import Check, check
from occlux_lab.cycles.cli import EXIT_DISAGREE, main

__all__ = ["EXIT_DISAGREE", "Check", "check", "main"]
