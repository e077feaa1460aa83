"""Occlux for Blender: load a scientific volume (or a time series of them, as an animated
volume), light it with Occlux, bring the results into the scene and the compositor, and check
them against Cycles.

Installed as a Blender 5 extension (the `occlux` wheel comes with it), or as a legacy add-on zip
when the `occlux` package is already importable in Blender's Python.
"""

bl_info = {
    "name": "Occlux",
    "author": "Occlux developers",
    "version": (0, 1, 0),
    "blender": (5, 0, 0),
    "location": "3D View > Sidebar > Occlux",
    "description": "Fast ambient occlusion and scattering for scientific volumes",
    "category": "Lighting",
}

from . import operators, panel, properties, transfer  # noqa: E402  (bl_info first)

_MODULES = (properties, transfer, operators, panel)


def register() -> None:
    for module in _MODULES:
        module.register()


def unregister() -> None:
    for module in reversed(_MODULES):
        module.unregister()
