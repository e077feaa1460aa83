"""The panel's transfer function as the scene's `classification`: a preset, or a ramp the user
edits, placed on a window of the file's values. The ramp is a Color Ramp node in a node group the
add-on owns (RGB: the albedo; alpha: the extinction over *Max density*), its positions 0 and 1
at the window's Low and High; it reaches the core as normalised control points on that window
(`range`), so that Occlux's grids, the AO, the bake and the material (whose points come from the
core's `Classification.raw_points`) all classify alike. The window and a ramp to start from are
the file's robust window and the ramp `occlux info --suggest` suggests on it
(`occlux.Volume.robust_window`). Each Volume object keeps, as CLASSIFIED, the classification it
shows, its file's robust window and a histogram of the file's values over the window it was
classified on (`occlux.Volume.histogram`), which the panel draws (`histogram_icon`)."""

from __future__ import annotations

import hashlib
import json
import math
from typing import Any

import bpy
import bpy.utils.previews
import occlux
from occlux.blender.material import fill_ramp

PRESET, RAMP = "PRESET", "RAMP"
# The node group holding the editable ramp, and its Color Ramp node.
RAMP_GROUP = "Occlux transfer function"
RAMP_NODE = "Ramp"
# The object's custom property holding what it shows (`kept`), as JSON.
CLASSIFIED = "occlux_classified"
# Bins of the kept histogram: as many as the panel's picture has columns.
HISTOGRAM_BINS = 64
# A ramp before any suggestion: clear at the window's Low, dense at its High (alpha 1: Max
# density), the albedo of `occlux info --suggest`'s clear and dense points.
FIRST_STOPS = ((0.0, (0.85, 0.8, 0.75, 0.0)), (1.0, (0.95, 0.93, 0.9, 1.0)))


def ramp_node(settings) -> bpy.types.ShaderNodeValToRGB | None:
    """The editable ramp's node (None before Ramp is first chosen, or once its group is gone)."""
    group = settings.ramp
    return None if group is None else group.nodes.get(RAMP_NODE)


def ensure_ramp(settings) -> bpy.types.ShaderNodeValToRGB:
    """The editable ramp's node, made with FIRST_STOPS in a node group of its own if missing."""
    node = ramp_node(settings)
    if node is not None:
        return node
    group = bpy.data.node_groups.new(RAMP_GROUP, "ShaderNodeTree")
    # Only the scene's settings point at it: kept in the .blend with no node using it.
    group.use_fake_user = True
    node = group.nodes.new("ShaderNodeValToRGB")
    node.name = node.label = RAMP_NODE
    fill_ramp(node.color_ramp, FIRST_STOPS)
    settings.ramp = group
    return node


def suggest(settings, robust: dict[str, Any]) -> None:
    """Sets the window to the file's robust window (`occlux.Volume.robust_window`: its cut of
    wrapped values too) and the ramp to the ramp suggested on it, Max density its densest
    point; the transfer function becomes the ramp."""
    lo, hi, cut = robust["lo"], robust["hi"], robust["cut"]
    settings.window_lo, settings.window_hi = lo, hi
    settings.use_window_cut = cut is not None
    if cut is not None:
        settings.window_cut = cut
    points = robust["points"]
    top = max(p[1] for p in points) or 1.0
    settings.max_density = top
    stops = [((p[0] - lo) / (hi - lo), (*p[2], p[1] / top)) for p in points]
    fill_ramp(ensure_ramp(settings).color_ramp, stops)
    settings.transfer = RAMP


def section(settings) -> dict[str, Any]:
    """The scene's `classification` for the panel's transfer function: the preset, or the
    ramp's elements as control points (position, alpha x Max density, RGB) on the window. A
    window without Low < High (or a cut not above High), a missing ramp or one that does not
    interpolate linearly in RGB (Occlux's transfer function is linear between its points) is
    refused in the panel's words."""
    scale = float(settings.density_scale)
    if settings.transfer == PRESET:
        return {"preset": settings.preset, "density_scale": scale}
    lo, hi = float(settings.window_lo), float(settings.window_hi)
    if not lo < hi:
        raise ValueError(f"the window's Low ({lo:g}) must be below its High ({hi:g})")
    window: dict[str, float] = {"lo": lo, "hi": hi}
    if settings.use_window_cut:
        if not settings.window_cut > hi:
            raise ValueError(
                f"the window's Cut ({settings.window_cut:g}) must be above its High ({hi:g})"
            )
        window["cut"] = float(settings.window_cut)
    node = ramp_node(settings)
    if node is None:
        raise ValueError(
            f"the transfer function has no ramp (its node group '{RAMP_GROUP}' is gone): "
            "choose Ramp again or press Suggest from File"
        )
    ramp = node.color_ramp
    if ramp.interpolation != "LINEAR" or ramp.color_mode != "RGB":
        raise ValueError(
            "the ramp must interpolate Linear in RGB (Occlux's transfer function is linear "
            f"between its points), not {ramp.interpolation.title()} in {ramp.color_mode}"
        )
    density = float(settings.max_density)
    points = [
        {
            "value": float(e.position),
            "sigma_t": float(e.alpha) * density,
            "albedo": [float(c) for c in e.color[:3]],
        }
        for e in ramp.elements
    ]
    return {"points": points, "range": window, "density_scale": scale}


def kept(volume: occlux.Volume, classified: dict[str, Any]) -> str:
    """What a Volume object keeps (CLASSIFIED): the `classification` it shows (`section`'s), its
    file's `robust` window and the `histogram` of the file's values over the window it was
    classified on (the robust one, for a preset), as JSON."""
    robust = volume.robust_window()
    window = classified.get("range", robust)
    lo, hi = float(window["lo"]), float(window["hi"])
    counts = volume.histogram(lo, hi, HISTOGRAM_BINS)
    histogram = {"lo": lo, "hi": hi, "counts": [int(n) for n in counts]}
    return json.dumps({"classification": classified, "robust": robust, "histogram": histogram})


def kept_by(obj: bpy.types.Object | None) -> dict[str, Any] | None:
    """What `obj` keeps (`kept`), None for an object that keeps nothing."""
    if obj is None or CLASSIFIED not in obj:
        return None
    return json.loads(obj[CLASSIFIED])


# The panel's histogram pictures (bpy.utils.previews), made on first draw; by object name, with
# the digest of the counts each shows.
_previews: bpy.utils.previews.ImagePreviewCollection | None = None
_shown: dict[str, str] = {}
# The picture: one column per bin, bars of log10(count + 1) (so that a small population, the
# embryo beside an egg's shell, shows beside the background's peak).
PICTURE = HISTOGRAM_BINS
BAR, GROUND = (0.85, 0.85, 0.85, 1.0), (0.1, 0.1, 0.1, 1.0)


def histogram_pixels(counts: list[int], width: int, height: int) -> list[float]:
    """RGBA floats, rows bottom up, of bars for `counts` (one column per count when `width`
    equals their number)."""
    top = math.log10(max(counts) + 1.0) or 1.0
    heights = [
        round(math.log10(counts[x * len(counts) // width] + 1.0) / top * height)
        for x in range(width)
    ]
    pixels: list[float] = []
    for y in range(height):
        for x in range(width):
            pixels.extend(BAR if y < heights[x] else GROUND)
    return pixels


def histogram_icon(obj: bpy.types.Object) -> int:
    """The icon id of the picture of `obj`'s kept histogram (0 when it keeps none)."""
    held = kept_by(obj)
    if held is None or _previews is None:
        return 0
    counts = held["histogram"]["counts"]
    digest = hashlib.sha256(json.dumps(counts).encode()).hexdigest()
    preview = _previews.get(obj.name) or _previews.new(obj.name)
    if _shown.get(obj.name) != digest:
        preview.image_size = preview.icon_size = (PICTURE, PICTURE)
        pixels = histogram_pixels(counts, PICTURE, PICTURE)
        preview.image_pixels_float = pixels
        preview.icon_pixels_float = pixels
        _shown[obj.name] = digest
    return preview.icon_id


def register() -> None:
    global _previews
    _previews = bpy.utils.previews.new()


def unregister() -> None:
    global _previews
    if _previews is not None:
        bpy.utils.previews.remove(_previews)
    _previews = None
    _shown.clear()
