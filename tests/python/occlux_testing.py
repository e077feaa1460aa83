"""Shared helpers for the Python tests: the CLI binary, an image reader, the measurement harness's
folder (`occlux_lab`, in lab/python, which is not installed) and (re-exported from
`occlux.blender`) the way to the modules bundled in the bpy wheel (OpenVDB 12, OpenImageIO)."""

from __future__ import annotations

import os
import subprocess
from pathlib import Path

import numpy as np
from occlux.blender import bpy_site_packages, bundled_module

REPO = Path(__file__).resolve().parents[2]
LAB = REPO / "lab" / "python"
"""The folder of the measurement harness ``occlux_lab``: conftest.py puts it on sys.path, and
:func:`lab_env` on the PYTHONPATH of a subprocess (as the ``occlux`` launchers do)."""


def lab_env() -> dict[str, str]:
    """This process's environment with LAB first on PYTHONPATH, for ``python -m occlux_lab...``."""
    paths = [str(LAB), *filter(None, os.environ.get("PYTHONPATH", "").split(os.pathsep))]
    return {**os.environ, "PYTHONPATH": os.pathsep.join(paths)}


def oiio_read(path: Path) -> dict[str, np.ndarray]:
    """Every channel of an image file, by name, as float32 arrays (row 0 at the top)."""
    oiio = bundled_module("OpenImageIO")
    image = oiio.ImageInput.open(str(path))
    assert image, oiio.geterror()
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


__all__ = [
    "LAB",
    "REPO",
    "bpy_site_packages",
    "bundled_module",
    "lab_env",
    "occlux_binary",
    "oiio_read",
    "run_occlux",
    "usd_validation_errors",
]
