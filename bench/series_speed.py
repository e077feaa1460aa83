"""Frames per minute of a time series: `occlux series` (frames in order, each frame's work
spread over every core by rayon) against `occlux.series` on a Dask LocalCluster of worker
processes (frames side by side, one thread each), measured side by side in one run, medians of
--repeats alternating runs, on a generated series (a moving, brightening ball: --frames NRRD
files of --side^3 float voxels).

    .venv/bin/python bench/series_speed.py --frames 16 --side 96 --repeats 3

Prints a table and JSON: the plan (every frame read once: the window and the camera fixed
across the frames), the frames per minute of each run, the per-frame cost and the bytes read
and written per frame, and what N machines would take for a series of --project frames by the
simple model time = plan + frames * per_frame / N (the plan on the client, reading every frame
once; per_frame as the LocalCluster achieved it on this machine; frames independent), with the
rate a shared file system must carry.
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import statistics
import subprocess
import tempfile
import time
from pathlib import Path

import distributed
import numpy as np
import occlux
import occlux.batch

REPO = Path(__file__).resolve().parents[1]

SCENE = """
[volume]
frames = "step_*.nrrd"
fit = "auto"
[classification]
preset = "simulation"
[camera]
width = {size}
height = {size}
[[lights]]
type = "directional"
direction = [-0.3, -1.0, 1.2]
irradiance = 4.0
[render]
method = "ipsvi"
"""


def make_series(folder: Path, frames: int, side: int, size: int) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    z, y, x = np.mgrid[0:side, 0:side, 0:side].astype(np.float32) / side
    for t in range(frames):
        d = np.sqrt((x - 0.3 - 0.4 * t / frames) ** 2 + (y - 0.5) ** 2 + (z - 0.5) ** 2)
        ripple = 0.1 * np.sin(40 * x + t) * np.sin(30 * y)
        values = (np.clip(0.3 - d + ripple * 0.2, 0, None) * 1000 * (1 + 0.05 * t)).astype("<f4")
        header = (
            f"NRRD0004\ntype: float\ndimension: 3\nsizes: {side} {side} {side}\n"
            "encoding: raw\nendian: little\nspacings: 1 1 1\n\n"
        )
        (folder / f"step_{t + 1:03}.nrrd").write_bytes(header.encode() + values.tobytes())
    scene = folder / "ball.toml"
    scene.write_text(SCENE.format(size=size))
    return scene


def folder_bytes(folder: Path, suffixes: tuple[str, ...]) -> int:
    return sum(p.stat().st_size for p in folder.iterdir() if p.suffix in suffixes)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--frames", type=int, default=16)
    parser.add_argument("--side", type=int, default=96)
    parser.add_argument("--size", type=int, default=128, help="image side in pixels")
    parser.add_argument("--ao", default="sweep-physical", help="--ao method ('' for none)")
    parser.add_argument("--workers", type=int, default=os.cpu_count() or 1)
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--project", type=int, default=500, help="frames of the projection")
    parser.add_argument("--json", type=Path, help="also write the results here")
    args = parser.parse_args()

    binary = Path(os.environ.get("OCCLUX_BIN", REPO / "target" / "release" / "occlux"))
    root = Path(tempfile.mkdtemp(prefix="occlux-series-bench-"))
    scene = make_series(root / "data", args.frames, args.side, args.size)
    ao = ["--ao", args.ao] if args.ao else []
    serial_s, dask_s, plan_s = [], [], []
    with (
        # The cluster occlux.series makes when given none, made once here so that its start
        # is not timed.
        distributed.LocalCluster(
            n_workers=args.workers,
            threads_per_worker=1,
            processes=True,
            dashboard_address=":0",
            env=dict(occlux.batch.WORKER_ENV),
        ) as cluster,
        distributed.Client(cluster) as client,
    ):
        # Warm-up: page cache, worker imports.
        occlux.series(scene, None, root / "warm", ao=args.ao or None, client=client)
        for _ in range(args.repeats):
            out = root / "serial"
            shutil.rmtree(out, ignore_errors=True)
            started = time.perf_counter()
            cmd = [str(binary), "series", str(scene), "--device", "cpu", "-o", str(out), *ao]
            subprocess.run([*cmd, "--quiet"], check=True)
            serial_s.append(time.perf_counter() - started)
            # The plan alone: a rerun on a complete folder reads every frame and skips them all.
            started = time.perf_counter()
            subprocess.run([*cmd, "--quiet"], check=True)
            plan_s.append(time.perf_counter() - started)

            out = root / "dask"
            shutil.rmtree(out, ignore_errors=True)
            started = time.perf_counter()
            occlux.series(scene, None, out, ao=args.ao or None, client=client)
            dask_s.append(time.perf_counter() - started)
    serial, dask, plan = (statistics.median(v) for v in (serial_s, dask_s, plan_s))
    per_frame = (serial - plan) / args.frames
    # One machine's frames run side by side on its workers: its time per frame, the plan aside.
    per_frame_dask = (dask - plan) / args.frames
    read = folder_bytes(root / "data", (".nrrd",)) / args.frames
    written = folder_bytes(root / "serial", (".vdb", ".exr", ".png")) / args.frames
    result = {
        "frames": args.frames,
        "voxels": args.side**3,
        "image": [args.size, args.size],
        "ao": args.ao or None,
        "cores": os.cpu_count(),
        "workers": args.workers,
        "plan_s": plan,
        "serial_s": serial,
        "dask_s": dask,
        "serial_frames_per_min": 60 * args.frames / serial,
        "dask_frames_per_min": 60 * args.frames / dask,
        "dask_over_serial": serial / dask,
        "per_frame_s": per_frame,
        "per_frame_dask_s": per_frame_dask,
        "bytes_read_per_frame": read,
        "bytes_written_per_frame": written,
        # N machines like this one: the plan reads every frame once on the client, then the
        # frames spread over the machines; the shared file system must carry every frame's
        # bytes in and out at the machines' combined rate.
        "projection": {
            str(n): {
                "minutes": (plan * args.project / args.frames + args.project * per_frame_dask / n)
                / 60,
                "shared_fs_mib_per_s": n * (read + written) / per_frame_dask / 2**20,
            }
            for n in (1, 4, 16, 64)
        },
    }
    print(f"{args.frames} frames of {args.side}^3, {args.size}^2 image, ao {args.ao or 'none'}")
    print(f"plan (every frame read once): {plan:.2f} s")
    print(f"serial (occlux series):      {serial:.2f} s, {result['serial_frames_per_min']:.1f}/min")
    print(
        f"Dask LocalCluster x{args.workers}:    {dask:.2f} s, "
        f"{result['dask_frames_per_min']:.1f}/min ({result['dask_over_serial']:.2f}x)"
    )
    print(
        f"per frame {per_frame:.3f} s; read {read / 2**20:.1f} MiB, write {written / 2**20:.2f} MiB"
    )
    for n, p in result["projection"].items():
        print(
            f"  {args.project} frames on {n} machine(s) like this one: {p['minutes']:.1f} min, "
            f"shared file system {p['shared_fs_mib_per_s']:.0f} MiB/s"
        )
    print(json.dumps(result, indent=2))
    if args.json is not None:
        args.json.write_text(json.dumps(result, indent=2))
    shutil.rmtree(root, ignore_errors=True)


if __name__ == "__main__":
    main()
