"""Load Series: a time series that `occlux series` wrote (a VDB per frame, `NAME_0001.vdb`,
`NAME_0002.vdb`, ..., and the manifest `NAME.series.json`) as one Volume object playing the
frames as Blender's volume sequence, from the scene's first frame, with the material of a single
volume (`volume.show`): the series' transfer function on the `value` grid and, when the series
has an `ao` grid, that grid shading it as Compute AO does."""

from __future__ import annotations

import json
import re
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import bpy
from bpy.props import StringProperty

from .. import material
from .volume import SERIES, FrameSequence, Shown, show

VERSION = 1  # the manifest's `occlux_series` this add-on reads
MANIFEST_SUFFIX = ".series.json"
# A frame's VDB: what Blender's sequences number, the digits just before the extension.
FRAME_VDB = re.compile(r"(?P<stem>.*?)(?P<digits>\d+)(?P<ext>\.vdb)", re.IGNORECASE)
# A frame's VDB as `occlux series` names it, whose manifest NAME.series.json lies beside it.
SERIES_VDB = re.compile(r"(?P<name>.+)_\d+\.vdb", re.IGNORECASE)


@dataclass(frozen=True)
class Series:
    """A series manifest, checked: its frames' VDBs (in frame order, all present), the grids
    each holds and the classification's control points on raw values (None: a 2D transfer
    function)."""

    manifest: Path
    name: str
    vdbs: tuple[Path, ...]
    first: int  # the number in the first VDB's name
    grids: tuple[str, ...]
    points: list[material.Point] | None
    box: tuple[material.Rgb, material.Rgb]  # the frames' cells' bounds, the same for all

    @property
    def sequence(self) -> FrameSequence:
        return FrameSequence(count=len(self.vdbs), first=self.first)


def manifest_path(typed: str) -> Path:
    """The manifest for the path as typed: the manifest itself, or NAME.series.json beside a
    frame's NAME_####.vdb. FileNotFoundError if there is none."""
    if not typed:
        raise FileNotFoundError("no series file set (Occlux panel > Series)")
    path = Path(bpy.path.abspath(typed))
    frame = SERIES_VDB.fullmatch(path.name)
    if frame is not None:
        manifest = path.with_name(frame["name"] + MANIFEST_SUFFIX)
        if not manifest.is_file():
            raise FileNotFoundError(
                f"no series manifest {manifest.name} beside {path.name} (in {path.parent})"
            )
        return manifest
    if not path.is_file():
        raise FileNotFoundError(f"no series manifest at '{path}'")
    return path


def _field(tree: dict[str, Any], key: str, kind: type | tuple[type, ...], where: str) -> Any:
    if key not in tree:
        raise ValueError(f"{where} has no '{key}'")
    value = tree[key]
    if not isinstance(value, kind) or isinstance(value, bool):
        raise ValueError(f"{where}: '{key}' is {json.dumps(value)}")
    return value


def _box(tree: dict[str, Any], where: str) -> tuple[material.Rgb, material.Rgb]:
    """The manifest's `settings.bounds`: [[x, y, z], [x, y, z]], the cells' bounds."""
    bounds = (
        tree.get("settings", {}).get("bounds") if isinstance(tree.get("settings"), dict) else None
    )
    try:
        lo, hi = (tuple(float(c) for c in corner) for corner in bounds)
        if len(lo) != 3 or len(hi) != 3:
            raise ValueError
    except (TypeError, ValueError) as e:
        raise ValueError(f"{where}: 'settings.bounds' is {json.dumps(bounds)}") from e
    return lo, hi


def _points(raw: Any, where: str) -> list[material.Point] | None:
    """The manifest's `raw_points`: [[value, sigma_t, [r, g, b], [r, g, b]], ...] or null."""
    if raw is None:
        return None
    try:
        points = [
            (float(v), float(s), tuple(float(c) for c in a), tuple(float(c) for c in e))
            for v, s, a, e in raw
        ]
    except (TypeError, ValueError):
        points = []
    if not points or any(len(p[2]) != 3 or len(p[3]) != 3 for p in points):
        raise ValueError(
            f"{where}: 'raw_points' is not a list of [value, sigma_t, [r, g, b], [r, g, b]]"
        )
    return points


def read_series(manifest: Path) -> Series:
    """The manifest, checked: ValueError for a file that is not one, of another version, or
    whose frames do not follow Blender's numbering; FileNotFoundError naming a frame whose VDB
    is missing, or when no frame has one (the series was run without VDB export)."""
    where = manifest.name
    try:
        tree = json.loads(manifest.read_text(encoding="utf-8"))
    except (UnicodeDecodeError, json.JSONDecodeError) as e:
        raise ValueError(f"{where} is not a series manifest (not valid JSON: {e})") from e
    if not isinstance(tree, dict) or "occlux_series" not in tree:
        raise ValueError(f"{where} is not an Occlux series manifest (no 'occlux_series')")
    version = tree["occlux_series"]
    if version != VERSION:
        newer = isinstance(version, int) and version > VERSION
        raise ValueError(
            f"{where}: unknown occlux_series version {json.dumps(version)} (this add-on reads "
            f"version {VERSION}{': update the Occlux extension' if newer else ''})"
        )
    name = _field(tree, "name", str, where)
    if not name:
        raise ValueError(f"{where}: 'name' is empty")
    frames = _field(tree, "frames", list, where)
    count = _field(tree, "count", int, where)
    if not frames or count != len(frames):
        raise ValueError(f"{where}: 'count' is {count} but {len(frames)} frames are listed")
    grids = tuple(_field(tree, "grids", list, where))
    if not all(isinstance(g, str) for g in grids):
        raise ValueError(f"{where}: 'grids' is {json.dumps(list(grids))}, not a list of names")
    points = _points(tree.get("raw_points"), where)
    if not all(isinstance(f, dict) for f in frames):
        raise ValueError(f"{where}: 'frames' is not a list of objects")
    numbers = [f.get("frame", k + 1) for k, f in enumerate(frames)]
    listed = [f.get("vdb") for f in frames]
    if all(vdb is None for vdb in listed):
        raise FileNotFoundError(
            f"{where} lists no VDB for any frame: the series was run without VDB export"
        )
    absent = [str(n) for n, vdb in zip(numbers, listed, strict=True) if not isinstance(vdb, str)]
    if absent:
        raise FileNotFoundError(f"{where} lists no VDB for frame {', '.join(absent)}")
    vdbs = tuple((manifest.parent / vdb).resolve() for vdb in listed)
    missing = [
        f"{path.name} (frame {n})"
        for n, path in zip(numbers, vdbs, strict=True)
        if not path.is_file()
    ]
    if missing:
        folder = manifest.parent
        raise FileNotFoundError(f"{where}: missing frame VDB {', '.join(missing)} in {folder}")
    first = FRAME_VDB.fullmatch(vdbs[0].name)
    if first is None:
        raise ValueError(f"{where}: the first frame's VDB {vdbs[0].name} has no frame number")
    # Blender finds frame k's file by putting first + k in place of the first file's digits.
    width, start = len(first["digits"]), int(first["digits"])
    for k, path in enumerate(vdbs):
        expected = vdbs[0].with_name(f"{first['stem']}{start + k:0{width}d}{first['ext']}")
        if path != expected:
            raise ValueError(
                f"{where}: frame {numbers[k]}'s VDB is {path.name}, but Blender plays "
                f"{expected.name} there (a sequence's files are numbered one after another in "
                "one folder)"
            )
    return Series(manifest.resolve(), name, vdbs, start, grids, points, _box(tree, where))


class OCCLUX_OT_import_series(bpy.types.Operator):
    """Load an Occlux time series (its manifest NAME.series.json, or one of its NAME_####.vdb
    frames) as one Volume object playing the frames from the scene's first frame"""

    bl_idname = "occlux.import_series"
    bl_label = "Load Series"
    bl_options = {"REGISTER", "UNDO"}

    filepath: StringProperty(
        name="Series",
        description="The series manifest NAME.series.json, or a frame's NAME_####.vdb beside "
        "it (empty: the Occlux panel's Series)",
        subtype="FILE_PATH",
        options={"SKIP_SAVE"},  # not remembered: the panel's Series is what an empty one reads
    )

    filter_glob: StringProperty(default="*.series.json;*.vdb", options={"HIDDEN"})

    def invoke(self, context: bpy.types.Context, event: bpy.types.Event) -> set[str]:
        """The file browser when no series is given (here or in the panel)."""
        if self.filepath or context.scene.occlux.series_path:
            return self.execute(context)
        context.window_manager.fileselect_add(self)
        return {"RUNNING_MODAL"}

    def execute(self, context: bpy.types.Context) -> set[str]:
        settings = context.scene.occlux
        try:
            series = read_series(manifest_path(self.filepath or settings.series_path))
            shown = Shown(
                name=series.name,
                vdb=series.vdbs[0],
                grids=series.grids,
                points=series.points,
                box=series.box,
                mark=SERIES,
                setting=str(series.manifest),
                owned=False,
                sequence=series.sequence,
            )
            ao = material.ao_shading(settings.ao_shading) if "ao" in series.grids else None
            obj = show(context, shown, ao, None)
        except (OSError, ValueError) as e:
            self.report({"ERROR"}, str(e))
            return {"CANCELLED"}
        scene = context.scene
        scene.frame_end = scene.frame_start + len(series.vdbs) - 1
        shading = "" if ao is None else f", shaded by its ao grid ({ao.lower()})"
        self.report(
            {"INFO"},
            f"loaded {len(series.vdbs)} frames of {series.name} as '{obj.name}' (scene frame "
            f"{scene.frame_start} shows {series.vdbs[0].name}){shading}; scene frames set to "
            f"{scene.frame_start}-{scene.frame_end}",
        )
        return {"FINISHED"}


CLASSES = (OCCLUX_OT_import_series,)
