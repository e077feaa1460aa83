"""Shared helpers for the Python tests: the CLI binary, and the readers bundled in the bpy wheel
(OpenVDB 12, OpenImageIO), which live outside sys.path."""

from __future__ import annotations

import os
import site
import subprocess
import sys
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[2]


def bpy_site_packages() -> Path:
    """The bpy wheel's bundled site-packages (openvdb, OpenImageIO, pxr, MaterialX)."""
    for root in site.getsitepackages():
        path = Path(root) / "bpy" / "5.0" / "python" / "lib" / "python3.11" / "site-packages"
        if path.is_dir():
            return path
    raise RuntimeError("the bpy 5.0 wheel is not installed in this Python (see .ci/run)")


def _with_bpy_site_packages() -> None:
    path = str(bpy_site_packages())
    if path not in sys.path:
        sys.path.append(path)


def oiio_read(path: Path) -> dict[str, np.ndarray]:
    """Every channel of an image file, by name, as float32 arrays (row 0 at the top)."""
    _with_bpy_site_packages()
    import OpenImageIO

    image = OpenImageIO.ImageInput.open(str(path))
    assert image, OpenImageIO.geterror()
    try:
        names = list(image.spec().channelnames)
        pixels = image.read_image(format="float")
    finally:
        image.close()
    return {name: pixels[..., c] for c, name in enumerate(names)}


def occlux_binary() -> Path:
    """The release CLI that .ci/run builds (or $OCCLUX_BIN)."""
    binary = Path(os.environ.get("OCCLUX_BIN", REPO / "target" / "release" / "occlux"))
    assert binary.is_file(), f"{binary} is missing: build it with `cargo build --release`"
    return binary


def run_occlux(*args: str) -> subprocess.CompletedProcess[str]:
    """Runs the CLI and fails the test with its stderr if it fails."""
    result = subprocess.run([str(occlux_binary()), *args], capture_output=True, text=True)
    assert result.returncode == 0, f"occlux {' '.join(args)} failed:\n{result.stderr}"
    return result


def usd_validation_errors(stage) -> list[str]:
    """What usdchecker's validators report for a stage (usd-core >= 25: UsdValidation)."""
    from pxr import UsdValidation

    registry = UsdValidation.ValidationRegistry()
    context = UsdValidation.ValidationContext(registry.GetOrLoadAllValidators())
    return [str(error.GetErrorAsString()) for error in context.Validate(stage)]
