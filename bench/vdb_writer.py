"""Benchmark: Occlux's OpenVDB writer against OpenVDB's own (`openvdb.write`, OpenVDB 12 from
the bpy wheel) on the same grid, side by side in one process.

The grid is engine.nrrd's density grid as `occlux export examples/engine.toml` writes it
(extinction per scene unit). For each storage option it reports the median write time over
--repeats runs and the file size, for both writers, and their ratios (Occlux / OpenVDB). Both
files are read back with OpenVDB and compared, so the ratios compare equal content.

    .venv/bin/python bench/vdb_writer.py [--repeats 7] [--scene examples/engine.toml]
"""

from __future__ import annotations

import argparse
import json
import statistics
import struct
import tempfile
import time
from pathlib import Path

import numpy as np
import occlux
from occlux.blender import bundled_module

REPO = Path(__file__).resolve().parents[1]


def median_seconds(write, repeats: int) -> float:
    write()  # warm-up: page cache, allocator
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        write()
        times.append(time.perf_counter() - start)
    return statistics.median(times)


def _read_str(f) -> bytes:
    (n,) = struct.unpack("<I", f.read(4))
    return f.read(n)


def compression_flags(path: Path) -> int:
    """The first grid's compression flags, read from a version-224 file's header."""
    with open(path, "rb") as f:
        f.read(8 + 4 + 8 + 1 + 36)  # magic, version, library version, offsets flag, uuid
        (entries,) = struct.unpack("<I", f.read(4))
        for _ in range(entries):  # file metadata: name, type, size, bytes
            _read_str(f), _read_str(f)
            (size,) = struct.unpack("<I", f.read(4))
            f.read(size)
        f.read(4)  # grid count
        _read_str(f), _read_str(f), _read_str(f)  # name, type, instance parent
        f.read(24)  # grid, block and end positions
        (flags,) = struct.unpack("<I", f.read(4))
    return flags


def describe_flags(flags: int) -> str:
    names = {1: "zip", 2: "active mask", 4: "blosc"}
    return " + ".join(name for bit, name in names.items() if flags & bit) or "none"


def openvdb_grid(openvdb, volume: occlux.Volume, half: bool):
    grid = openvdb.FloatGrid(0.0)
    grid.name = "density"
    grid.gridClass = openvdb.GridClass.FOG_VOLUME
    # occlux's values are (z, y, x); OpenVDB's copyFromArray takes (x, y, z). The same grid as
    # Occlux writes: padded by one voxel repeating the border (src/export/vdb.rs).
    padded = np.pad(volume.values, 1, mode="edge").transpose(2, 1, 0)
    grid.copyFromArray(np.ascontiguousarray(padded), ijk=(-1, -1, -1), tolerance=0.0)
    voxel = volume.spacing[0]
    transform = openvdb.createLinearTransform(voxelSize=voxel)
    transform.postTranslate(volume.origin)
    grid.transform = transform
    grid.saveFloatAsHalf = half
    return grid


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--scene", type=Path, default=REPO / "examples" / "engine.toml")
    parser.add_argument("--repeats", type=int, default=7)
    parser.add_argument("--json", type=Path, help="also write the table as JSON here")
    args = parser.parse_args()
    openvdb = bundled_module("openvdb")

    scene = occlux.Scene.load(args.scene)
    volume = scene.load_volume()
    density = scene.classification.extinction(volume)
    active = int(np.count_nonzero(np.pad(density.values, 1, mode="edge")))
    print(f"grid: {args.scene.stem} density, dims {density.dims}, {active} active voxels")
    print(f"OpenVDB {openvdb.LIBRARY_VERSION}, occlux {occlux.__version__}, {args.repeats} repeats")

    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        # OpenVDB's Python `write` always uses its default compression (read back from the
        # file: zip or blosc, plus the active mask), with or without half floats.
        theirs = {}
        for half in (False, True):
            path = Path(tmp) / f"openvdb-{half}.vdb"
            grid = openvdb_grid(openvdb, density, half)
            seconds = median_seconds(
                lambda p=path, g=grid: openvdb.write(str(p), grids=[g]), args.repeats
            )
            theirs[half] = (path, seconds)
        flags = compression_flags(theirs[False][0])
        print(f"OpenVDB writes with compression flags {flags} ({describe_flags(flags)})")
        for label, compression, half in [
            ("uncompressed", "none", False),
            ("zip", "zip", False),
            ("half", "none", True),
            ("zip + half", "zip", True),
        ]:
            ours = Path(tmp) / f"occlux-{compression}-{half}.vdb"
            seconds = median_seconds(
                lambda p=ours, c=compression, h=half: occlux.write_vdb(
                    p, {"density": density}, compression=c, half=h
                ),
                args.repeats,
            )
            their_path, their_seconds = theirs[half]
            a, b = (openvdb.read(str(p), "density") for p in (ours, their_path))
            assert a.activeVoxelCount() == b.activeVoxelCount() == active
            rows.append(
                {
                    "occlux": label,
                    "openvdb": f"default{' + half' if half else ''}",
                    "occlux_ms": 1e3 * seconds,
                    "openvdb_ms": 1e3 * their_seconds,
                    "time_ratio": seconds / their_seconds,
                    "occlux_bytes": ours.stat().st_size,
                    "openvdb_bytes": their_path.stat().st_size,
                    "size_ratio": ours.stat().st_size / their_path.stat().st_size,
                }
            )

    print(
        f"{'occlux':<14}{'vs openvdb':<16}{'occlux ms':>10}{'openvdb ms':>12}{'time x':>8}"
        f"{'occlux MB':>11}{'openvdb MB':>12}{'size x':>8}"
    )
    for r in rows:
        print(
            f"{r['occlux']:<14}{r['openvdb']:<16}{r['occlux_ms']:>10.1f}{r['openvdb_ms']:>12.1f}"
            f"{r['time_ratio']:>8.2f}{r['occlux_bytes'] / 1e6:>11.2f}"
            f"{r['openvdb_bytes'] / 1e6:>12.2f}{r['size_ratio']:>8.2f}"
        )
    if args.json:
        args.json.write_text(json.dumps(rows, indent=2))


if __name__ == "__main__":
    main()
