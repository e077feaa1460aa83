"""Fixtures shared by the Python tests.

The readers that check Occlux's files (OpenVDB 12, OpenImageIO) come with the bpy wheel, in a
site-packages folder that is not on sys.path: the ``bpy_site_packages`` fixture puts it there
(the plain function is ``occlux_testing.bpy_site_packages``). The measurement harness
``occlux_lab`` is not installed: its folder, lab/python, goes on sys.path here (subprocesses get
it on PYTHONPATH from ``occlux_testing.lab_env``). GPU tests run on whatever adapter
wgpu opens (lavapipe in CI); with ``OCCLUX_REQUIRE_GPU=1`` (CI) a missing GPU fails them instead
of skipping them.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest
from occlux_testing import LAB, REPO
from occlux_testing import bpy_site_packages as find_bpy_site_packages

if str(LAB) not in sys.path:
    sys.path.insert(0, str(LAB))


def gpu_required() -> bool:
    """Whether a missing GPU is a failure (CI) rather than a skip."""
    return os.environ.get("OCCLUX_REQUIRE_GPU", "") not in ("", "0")


@pytest.fixture(scope="session")
def bpy_site_packages() -> Path:
    """The bpy wheel's bundled site-packages, added to sys.path (openvdb, OpenImageIO, pxr)."""
    path = find_bpy_site_packages()
    if str(path) not in sys.path:
        sys.path.append(str(path))
    return path


@pytest.fixture(scope="session")
def openvdb(bpy_site_packages: Path):
    """Real OpenVDB 12, from the bpy wheel."""
    import openvdb

    return openvdb


@pytest.fixture(scope="session")
def oiio(bpy_site_packages: Path):
    """OpenImageIO, from the bpy wheel."""
    import OpenImageIO

    return OpenImageIO


@pytest.fixture(scope="session")
def gpu_device() -> str:
    """The device name "gpu" if an adapter opens; otherwise the test is skipped, or fails
    under OCCLUX_REQUIRE_GPU=1."""
    import occlux

    probe = occlux.Scene.from_toml(
        '[volume]\nphantom = "sphere"\nsize = 4\n[camera]\nposition = [0, -4, 0]\n'
        "width = 2\nheight = 2\n"
    )
    try:
        occlux.render(probe, device="gpu")
    except occlux.OccluxError as e:
        message = f"no GPU adapter: {e}"
        if gpu_required():
            pytest.fail(f"{message} (OCCLUX_REQUIRE_GPU is set)")
        pytest.skip(message)
    return "gpu"


@pytest.fixture(scope="session")
def extension(tmp_path_factory) -> Path:
    """The extension zip, built once per run with the add-on's build script (maturin wheel
    inside, for this machine's glibc: the portable wheel would build every dependency again),
    for every test that installs it in Blender."""
    out = tmp_path_factory.mktemp("dist")
    subprocess.run(
        [sys.executable, str(REPO / "blender_addon" / "build.py"), "--native", "--out", str(out)],
        check=True,
        capture_output=True,
    )
    return out / "occlux-0.1.0.zip"
