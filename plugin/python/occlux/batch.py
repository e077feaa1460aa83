"""Time series and batches on a Dask cluster: every frame of a series as one Dask task.

``occlux series`` (the command line) runs a series' frames in order on one machine; this
module (``occlux.series``) runs the same frames as tasks of `Dask distributed
<https://distributed.dask.org>`_, on a LocalCluster of processes by default or on any cluster
whose ``distributed.Client`` (or scheduler address) is given::

    import occlux

    done = occlux.series("sim.toml", "data/step_*.nrrd", "out/")   # a LocalCluster
    done = occlux.series("sim.toml", None, "out/", client="tcp://scheduler:8786")
    done.stage     # out/sim.usda: the grids as time samples
    done.written   # {frame: [files]}, done.complete: frames an earlier run finished

The work is the core's, in three steps: the plan reads every frame once here (frames of other
dims or spacing are refused before any work), fixes the classification's window and the camera
across the frames and writes the manifest ``OUT/NAME.series.json``; each task reads the
manifest and writes its frame's files as one atomic set, with the GIL released; the stage is
written once every frame is there. The output is byte for byte what ``occlux series`` writes.

A frame whose worker dies is rerun by the scheduler on another worker; a frame that fails is
retried ``retries`` times, and whatever still fails is named in a :class:`SeriesError` after the
other frames are done: never a silently missing frame. A rerun resumes: frames already complete
are skipped. Workers must see the same files (the frames, the output folder) as this process.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from occlux import _occlux

__all__ = ["SeriesError", "SeriesResult", "series"]

#: How long to wait for a scheduler given by address before saying it cannot be reached.
CONNECT_TIMEOUT_S = 10
#: The environment of the LocalCluster's workers: one worker per core, each frame's work on one
#: thread (the core's rayon pool would otherwise start a thread per core in every worker).
WORKER_ENV = {"RAYON_NUM_THREADS": "1"}


class SeriesError(RuntimeError):
    """Frames of a series failed (``failed`` maps each to why), or no cluster could be reached."""

    def __init__(self, message: str, failed: dict[int, str] | None = None) -> None:
        super().__init__(message)
        self.failed = failed or {}


@dataclass
class SeriesResult:
    """What a run did: the manifest, the files each frame wrote, the frames an earlier run had
    completed (skipped), and the USD stage (None without export)."""

    manifest: Path
    written: dict[int, list[Path]] = field(default_factory=dict)
    complete: list[int] = field(default_factory=list)
    stage: Path | None = None


def run_frame(manifest: str, frame: int, device: str) -> tuple[int, str, list[str]]:
    """One task: frame ``frame`` of the series of ``manifest`` (the core releases the GIL)."""
    status, files = _occlux.series_frame(manifest, frame, device)
    return frame, status, [str(f) for f in files]


def series(
    scene: str | os.PathLike | dict,
    frames: str | Sequence[str | os.PathLike] | None,
    out: str | os.PathLike,
    *,
    name: str | None = None,
    render: bool = True,
    export: bool = True,
    ao: str | None = None,
    ao_radius: int = 10,
    half: bool = False,
    zip: bool = True,
    float32: bool = False,
    exposure: float = 1.0,
    base_dir: str | os.PathLike = ".",
    client: Any = None,
    workers: int | None = None,
    retries: int = 2,
    device: str = "cpu",
    progress: Callable[[int, int], None] | None = None,
) -> SeriesResult:
    """Renders and exports every frame of a series as Dask tasks; returns what was written.

    ``scene``: a TOML scene file, or its tree as a dict (relative paths against ``base_dir``).
    ``frames``: a pattern or folder, a list of files, or None for the scene's ``volume.frames``.
    ``render``/``export``/``ao``/...: the outputs, as ``occlux series`` takes them.
    ``client``: a ``distributed.Client``, a scheduler's address, or None for a LocalCluster of
    ``workers`` processes (one thread each; default: one per core) made and closed here.
    ``device``: where each task computes ("cpu" by default: GPU workers need an adapter each).
    ``progress``: called with ``(done, total)`` as frames finish.
    """
    distributed = _distributed()
    # Reach the cluster before anything is written: an unreachable scheduler leaves no files.
    own_cluster = None
    if client is None:
        own_cluster = distributed.LocalCluster(
            n_workers=workers or os.cpu_count() or 1,
            threads_per_worker=1,
            processes=True,
            dashboard_address=":0",
            env=dict(WORKER_ENV),
        )
        client = distributed.Client(own_cluster)
    elif isinstance(client, str):
        client = _connect(distributed, client)
    try:
        options = {
            "render": render,
            "export": export,
            "ao": ao,
            "ao_radius": ao_radius,
            "zip": zip,
            "half": half,
            "float32": float32,
            "exposure": exposure,
        }
        if isinstance(scene, os.PathLike):
            scene = os.fspath(scene)
        if name is None:
            name = Path(scene).stem if isinstance(scene, str) else "series"
        if frames is not None and not isinstance(frames, str):
            frames = [os.fspath(f) for f in frames]
        manifest, _ = _occlux.series_plan(
            scene, frames, os.fspath(out), name, options, base_dir=os.fspath(base_dir)
        )
        return _run_tasks(distributed, client, Path(manifest), retries, device, progress)
    finally:
        if own_cluster is not None:
            client.close()
            own_cluster.close()


def _distributed():
    try:
        import distributed
    except ImportError as error:
        raise SeriesError(
            "occlux.series runs frames on Dask: pip install 'occlux[dask]' (distributed)"
        ) from error
    return distributed


def _connect(distributed, address: str):
    try:
        return distributed.Client(address, timeout=CONNECT_TIMEOUT_S)
    except (OSError, TimeoutError) as error:
        raise SeriesError(
            f"cannot reach the Dask scheduler at {address} ({error}); nothing was written"
        ) from error


def _run_tasks(
    distributed,
    client,
    manifest: Path,
    retries: int,
    device: str,
    progress: Callable[[int, int], None] | None,
) -> SeriesResult:
    import json

    frames = [entry["frame"] for entry in json.loads(manifest.read_text())["frames"]]
    futures = {
        client.submit(run_frame, str(manifest), frame, device, retries=retries, pure=False): frame
        for frame in frames
    }
    result = SeriesResult(manifest=manifest)
    failed: dict[int, str] = {}
    for done, future in enumerate(distributed.as_completed(futures), start=1):
        frame = futures[future]
        try:
            _, status, files = future.result()
        except Exception as error:  # every failure is reported by frame
            failed[frame] = f"{type(error).__name__}: {error}"
        else:
            if status == "complete":
                result.complete.append(frame)
            else:
                result.written[frame] = [Path(f) for f in files]
        if progress is not None:
            progress(done, len(frames))
    if failed:
        lines = "\n".join(f"frame {f}: {why}" for f, why in sorted(failed.items()))
        raise SeriesError(
            f"{len(failed)} of {len(frames)} frames failed (a rerun redoes only these):\n{lines}",
            failed,
        )
    result.complete.sort()
    stage = _occlux.series_finish(str(manifest))
    result.stage = Path(stage) if stage is not None else None
    return result
