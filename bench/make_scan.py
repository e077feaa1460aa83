"""Writes a synthetic CT-like scan as a raw-encoded NRRD, slice by slice (memory: one slice).

The specimen is what a micro-CT holds: soft tissue (an ellipsoid, value 1000) inside a bone
shell (3000), with two air cavities and a dense rod (4000), in air (0) that fills most of the
box, plus the scanner's noise (a normal of sigma 20, fixed seed) everywhere. The values are
those of a 12-bit scanner, stored as uint16 or float32, so the two types hold the same scan.

    .venv/bin/python bench/make_scan.py --size 1024 --type uint16 --out /tmp/scan1024.nrrd

The memory benchmark (`bench/memory.sh`) makes its inputs with it.
"""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

import numpy as np

TYPES = {"uint16": np.dtype("<u2"), "float32": np.dtype("<f4")}


def slice_values(z: float, size: int, noise: np.random.Generator) -> np.ndarray:
    """One z slice of the scan in [-1, 1]^3 coordinates, as float32 scanner values."""
    axis = (np.arange(size, dtype=np.float32) + 0.5) / size * 2.0 - 1.0
    x, y = np.meshgrid(axis, axis, indexing="xy")
    # The specimen's ellipsoid: its level r2 = 1 is the bone's outer face.
    r2 = (x / 0.62) ** 2 + (y / 0.48) ** 2 + (z / 0.7) ** 2
    values = np.zeros((size, size), dtype=np.float32)
    values[r2 < 1.0] = 3000.0
    values[r2 < 0.8] = 1000.0
    for cx, cy, cz, radius in ((0.2, 0.1, 0.15, 0.16), (-0.25, -0.1, -0.2, 0.12)):
        cavity = (x - cx) ** 2 + (y - cy) ** 2 + (z - cz) ** 2 < radius**2
        values[cavity] = 0.0
    rod = ((x + 0.05) ** 2 + (y - 0.18) ** 2 < 0.04**2) & (abs(z) < 0.5)
    values[rod] = 4000.0
    values += noise.normal(0.0, 20.0, values.shape).astype(np.float32)
    return values


def write_scan(out: Path, size: int, dtype: np.dtype) -> None:
    header = (
        "NRRD0004\n"
        f"type: {'uint16' if dtype.kind == 'u' else 'float'}\n"
        "dimension: 3\n"
        f"sizes: {size} {size} {size}\n"
        "spacings: 1 1 1\n"
        "encoding: raw\n"
        "endian: little\n\n"
    )
    noise = np.random.default_rng(7)
    partial = out.with_name(out.name + ".partial")
    with open(partial, "wb") as file:
        file.write(header.encode("ascii"))
        for k in range(size):
            z = (k + 0.5) / size * 2.0 - 1.0
            values = slice_values(z, size, noise)
            if dtype.kind == "u":
                values = np.clip(np.rint(values), 0, 65535)
            file.write(values.astype(dtype).tobytes())
    os.replace(partial, out)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--size", type=int, default=512, help="voxels per side")
    parser.add_argument("--type", choices=sorted(TYPES), default="float32")
    parser.add_argument("--out", type=Path, required=True)
    args = parser.parse_args()
    if not 2 <= args.size <= 4096:
        parser.error(f"--size must be in [2, 4096], got {args.size}")
    write_scan(args.out, args.size, TYPES[args.type])
    return 0


if __name__ == "__main__":
    sys.exit(main())
