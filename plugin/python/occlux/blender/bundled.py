"""The Python packages Blender bundles (OpenImageIO, OpenVDB, USD), which the bpy wheel does not
put on sys.path."""

from __future__ import annotations

import importlib
import site
import sys
from pathlib import Path

from .common import HarnessError


def bpy_site_packages() -> Path:
    """The folder of the Python packages Blender bundles (OpenImageIO, OpenVDB, USD), which the
    bpy wheel does not put on sys.path."""
    for root in site.getsitepackages():
        path = Path(root) / "bpy" / "5.0" / "python" / "lib" / "python3.11" / "site-packages"
        if path.is_dir():
            return path
    raise HarnessError("the bpy 5.0 wheel is not installed in this Python")


def bundled_module(name: str):
    """A module that Blender bundles (``OpenImageIO``, ``openvdb``): importable inside Blender,
    from the bpy wheel's own site-packages otherwise."""
    try:
        return importlib.import_module(name)
    except ImportError:
        sys.path.append(str(bpy_site_packages()))
        return importlib.import_module(name)
