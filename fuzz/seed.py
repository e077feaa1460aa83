"""Seed corpora for the fuzz targets, made from the shared volumes (../shared/data/scivis).

Usage: python3 fuzz/seed.py OCCLUX_BINARY OUT_FOLDER [SHARED_FOLDER]

Each shared NRRD gives a small valid NRRD with its own header fields (its sizes cut to a
16 x 8 x 4 block of its first voxels, gzip as it was, raw beside it), the start of the real file
(a truncated one), and the same block as NIfTI (sform axis-aligned, permuted and oblique; plain
and gzipped), NumPy, raw (with the raw target's 12-byte layout prefix) and VDB (written by
`occlux export`, plain and half floats). The scene target gets the example scenes, the settle
target the same behind the byte that picks its phantom. The roundtrip and render targets read
their inputs as a stream of choices, the longer the larger their grids and the more of their
parameters they set: they get a few streams of fixed pseudo-random bytes of growing length.
Only the standard library is used.
"""

from __future__ import annotations

import gzip
import math
import random
import re
import struct
import subprocess
import sys
import tempfile
from pathlib import Path

BLOCK = (16, 8, 4)
# NRRD type name -> (struct code, NIfTI datatype, numpy descr, index in ScalarType::ALL).
TYPES = {
    "uint8": ("B", 2, "|u1", 0),
    "uchar": ("B", 2, "|u1", 0),
    "uint16": ("H", 512, "<u2", 2),
    "ushort": ("H", 512, "<u2", 2),
    "int16": ("h", 4, "<i2", 3),
    "short": ("h", 4, "<i2", 3),
    "float": ("f", 16, "<f4", 6),
    "double": ("d", 64, "<f8", 7),
}


def split_nrrd(data: bytes) -> tuple[dict[str, str], list[str], bytes]:
    """The fields, the header lines and the payload of an attached NRRD."""
    end = data.index(b"\n\n")
    lines = data[:end].decode("latin-1").split("\n")
    fields = {}
    for line in lines[1:]:
        if ":" in line and not line.startswith("#"):
            key, value = line.split(":", 1)
            fields[key.strip().lower()] = value.strip()
    return fields, lines, data[end + 2 :]


def block_of(fields: dict[str, str], payload: bytes) -> tuple[str, bytes]:
    """The struct code and the raw little-endian bytes of the block of first voxels."""
    code = TYPES[fields["type"].lower()][0]
    raw = gzip.decompress(payload) if fields.get("encoding") == "gzip" else payload
    size = struct.calcsize(code)
    count = BLOCK[0] * BLOCK[1] * BLOCK[2]
    values = struct.unpack(f"<{count}{code}", raw[: count * size])
    return code, struct.pack(f"<{count}{code}", *values)


def nrrd_with(lines: list[str], encoding: str, data: bytes) -> bytes:
    out = []
    for line in lines:
        if line.lower().startswith("sizes:"):
            line = "sizes: {} {} {}".format(*BLOCK)
        elif line.lower().startswith("encoding:"):
            line = f"encoding: {encoding}"
        out.append(line)
    body = gzip.compress(data) if encoding == "gzip" else data
    return ("\n".join(out) + "\n\n").encode("latin-1") + body


def nifti(code: str, datatype: int, data: bytes, columns: list[list[float]]) -> bytes:
    """A NIfTI-1 file whose sform has these columns (index axis steps) and origin 0."""
    header = bytearray(352)
    struct.pack_into("<i", header, 0, 348)
    struct.pack_into("<8h", header, 40, 3, *BLOCK, 1, 1, 1, 1)
    struct.pack_into("<hh", header, 70, datatype, 8 * struct.calcsize(code))
    struct.pack_into("<8f", header, 76, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0)
    struct.pack_into("<f", header, 108, 352.0)
    struct.pack_into("<hh", header, 252, 1, 1)
    for row in range(3):
        srow = [columns[a][row] for a in range(3)] + [float(row)]
        struct.pack_into("<4f", header, 280 + 16 * row, *srow)
    header[344:348] = b"n+1\0"
    return bytes(header) + data


def npy(descr: str, data: bytes) -> bytes:
    shape = (BLOCK[2], BLOCK[1], BLOCK[0])
    text = f"{{'descr': '{descr}', 'fortran_order': False, 'shape': {shape!r}, }}"
    pad = 64 - (10 + len(text) + 1) % 64
    text += " " * pad + "\n"
    return b"\x93NUMPY\x01\x00" + struct.pack("<H", len(text)) + text.encode() + data


def main() -> None:
    occlux, out = Path(sys.argv[1]), Path(sys.argv[2])
    shared = Path(sys.argv[3]) if len(sys.argv) > 3 else Path(__file__).parents[2] / "shared"
    targets = ("nrrd", "nifti", "npy", "raw", "vdb", "scene", "settle", "roundtrip", "render")
    folders = {name: out / name for name in targets}
    for folder in folders.values():
        folder.mkdir(parents=True, exist_ok=True)
    angle = math.radians(20)
    frames = {
        "aligned": [[1, 0, 0], [0, 1.5, 0], [0, 0, 2]],
        "permuted": [[0, -1, 0], [0, 0, 1.5], [-2, 0, 0]],
        "oblique": [
            [math.cos(angle), math.sin(angle), 0],
            [-math.sin(angle), math.cos(angle), 0],
            [0, 0, 1],
        ],
    }
    for path in sorted((shared / "data" / "scivis").glob("*.nrrd")):
        data = path.read_bytes()
        fields, lines, payload = split_nrrd(data)
        if fields.get("type", "").lower() not in TYPES:
            continue
        code, block = block_of(fields, payload)
        _, datatype, descr, scalar = TYPES[fields["type"].lower()]
        stem = path.stem
        (folders["nrrd"] / f"{stem}-gzip.nrrd").write_bytes(nrrd_with(lines, "gzip", block))
        (folders["nrrd"] / f"{stem}-raw.nrrd").write_bytes(nrrd_with(lines, "raw", block))
        (folders["nrrd"] / f"{stem}-head.nrrd").write_bytes(data[:4096])
        for name, columns in frames.items():
            file = nifti(code, datatype, block, columns)
            (folders["nifti"] / f"{stem}-{name}.nii").write_bytes(b"\0" + file)
            (folders["nifti"] / f"{stem}-{name}.nii.gz").write_bytes(b"\1" + gzip.compress(file))
        (folders["npy"] / f"{stem}.npy").write_bytes(npy(descr, block))
        layout = bytes([*BLOCK, scalar, 0, 0, 0, 0, 0, 0, 0, 0])
        (folders["raw"] / f"{stem}.raw").write_bytes(layout + block)
        with tempfile.TemporaryDirectory() as work:
            small = Path(work) / "small.nrrd"
            small.write_bytes(nrrd_with(lines, "gzip", block))
            scene = Path(work) / "scene.toml"
            scene.write_text(
                f'[volume]\npath = "{small}"\n[classification]\nunits = "raw"\n'
                "points = [{ value = -1e9, sigma_t = 1 }, { value = 1e9, sigma_t = 2 }]\n"
                "[camera]\nposition = [40, -40, 30]\ntarget = [8, 4, 2]\nwidth = 8\nheight = 8\n"
            )
            for half in ([], ["--half"]):
                target = Path(work) / "out"
                command = [str(occlux), "export", str(scene), "-o", str(target)]
                subprocess.run([*command, "--device", "cpu", "--quiet", *half], check=True)
                suffix = "-half" if half else ""
                for vdb in target.glob("*.vdb"):
                    seed = folders["vdb"] / f"{stem}-{vdb.stem}{suffix}.vdb"
                    seed.write_bytes(vdb.read_bytes())
    examples = sorted((Path(__file__).parents[1] / "examples").glob("*.toml"))
    for pick, example in enumerate(examples):
        text = re.sub(r"\n\s*\n", "\n", example.read_text())
        (folders["scene"] / example.name).write_text(text)
        # The settle target's first byte b picks phantom b % 7 at side 8 + (b // 7) % 9: spread
        # over the examples, so that each phantom and several sides come up.
        first = bytes([pick * 37 % 256])
        (folders["settle"] / example.name).write_bytes(first + text.encode())
    stream = random.Random(20240601)
    for length in (256, 1024, 4096, 16384):
        for name in ("roundtrip", "render"):
            (folders[name] / f"random-{length}").write_bytes(stream.randbytes(length))
    for name, folder in folders.items():
        print(f"{name}: {len(list(folder.iterdir()))} seeds")


if __name__ == "__main__":
    main()
