"""EEVEE's settings that the add-on changes for its volumes, and how they are put back: the
user's value of each setting is remembered when the add-on first changes it (the scene's custom
property EEVEE_BEFORE, JSON) until Restore EEVEE Settings (`restore`) puts them all back."""

from __future__ import annotations

import json
from typing import Any

import bpy

# The scene's custom property holding the EEVEE settings before the add-on changed them.
EEVEE_BEFORE = "occlux_eevee_before"

# EEVEE's factory scene clamps the indirect light in volumes to 1e-8 (`clamp_volume_indirect`),
# which scales the world's light that a plain volume scatters (its only light, with no lamp)
# down to black; 0 is no clamp. Load Volume and Bake Light set it.
UNCLAMPED = {"clamp_volume_indirect": 0.0}


def change(scene: bpy.types.Scene, wanted: dict[str, Any]) -> list[str]:
    """Sets the EEVEE settings `wanted` (name: value), remembering the user's value of each it
    changes (once, until restored), and returns what changed, e.g. "EEVEE
    clamp_volume_indirect 1e-08 -> 0"."""
    eevee = scene.eevee
    saved = json.loads(scene[EEVEE_BEFORE]) if EEVEE_BEFORE in scene else {}
    changed = []
    for key, value in wanted.items():
        before = getattr(eevee, key)
        if before == value:
            continue
        saved.setdefault(key, before)
        setattr(eevee, key, value)
        changed.append(f"EEVEE {key} {_shown(before)} -> {_shown(getattr(eevee, key))}")
    if saved:
        scene[EEVEE_BEFORE] = json.dumps(saved)
    return changed


def _shown(value: Any) -> str:
    """A setting's value as a report says it (floats to 3 digits: EEVEE's are single)."""
    return f"{value:.3g}" if isinstance(value, float) else str(value)


def restore(scene: bpy.types.Scene) -> bool:
    """Puts back the EEVEE settings the add-on changed; False if it changed none."""
    if EEVEE_BEFORE not in scene:
        return False
    for key, value in json.loads(scene[EEVEE_BEFORE]).items():
        setattr(scene.eevee, key, value)
    del scene[EEVEE_BEFORE]
    return True
