"""Load Series in the Blender extension, headless (bpy in a subprocess, the extension built,
installed and enabled as in test_addon.py): the VDBs of a time series as one Volume object that
plays them as Blender's volume sequence, frame by frame, with the material of a single volume,
and clear errors that add nothing.

The series is made by the CLI, `occlux series`."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from occlux_testing import run_occlux
from test_addon import CAMERA_AND_WORLD, blender

PRESET = "ct-soft-tissue"
SIZE = 64  # voxels along each side: a sphere's bounds in 8-voxel leaves grow with its radius


def sphere(k: int) -> np.ndarray:
    """Frame k's values (k = 1, 2, ...): a sphere whose radius grows by 8 voxels a frame (6 at
    frame 1, up to the volume's half width), densest at its centre and 0 outside it."""
    radius = min(6.0 + 8.0 * (k - 1), SIZE / 2 - 1)
    z, y, x = np.mgrid[0:SIZE, 0:SIZE, 0:SIZE].astype(np.float32) - (SIZE - 1) / 2
    r = np.sqrt(x * x + y * y + z * z)
    return (1000.0 * np.clip(1.0 - r / radius, 0.0, 1.0)).astype(np.float32)


def make_series(folder: Path, count: int = 4, with_ao: bool = True) -> Path:
    """A series made by `occlux series`: `count` frames of a growing sphere (`sphere`, fitted to
    2 units and centred) as `step_KK.npy`, exported as `series_KKKK.vdb` (`density`, `value`
    and, `with_ao`, the `ao` of `--ao cdf`) with the manifest `series.series.json`; returns the
    manifest's path."""
    folder.mkdir(parents=True, exist_ok=True)
    for k in range(1, count + 1):
        np.save(folder / f"step_{k:02d}.npy", sphere(k))
    scene = folder / "series.toml"
    scene.write_text(
        f"""
[volume]
frames = "step_*.npy"
fit = "auto"
centre = [0, 0, 0]
[classification]
preset = "{PRESET}"
[camera]
position = [0, -6, 0]
width = 16
height = 16
[[lights]]
type = "ambient"
radiance = 1.0
"""
    )
    ao = ["--ao", "cdf", "--ao-radius", "4"] if with_ao else []
    run_occlux("series", str(scene), "--export", "--device", "cpu", "-o", str(folder), *ao)
    return folder / "series.series.json"


# The material's wiring, comparable across objects: its links by node type and socket, the
# grids it reads, its named Occlux nodes and their values, and the range the ramps span (the
# transfer function's raw values).
WIRING = """
def wiring(obj):
    tree = obj.data.materials[0].node_tree
    links = sorted([l.from_node.bl_idname, l.from_socket.identifier, l.to_node.bl_idname,
                    l.to_socket.identifier] for l in tree.links)
    grids = sorted(n.attribute_name for n in tree.nodes if n.bl_idname == "ShaderNodeAttribute")
    named = sorted([n.name, [round(x, 6) for x in n.outputs[0].default_value]
                    if n.bl_idname == "ShaderNodeRGB" else round(n.outputs[0].default_value, 6)]
                   for n in tree.nodes if n.name.startswith("Occlux"))
    ranges = sorted([round(n.inputs["From Min"].default_value, 4),
                     round(n.inputs["From Max"].default_value, 4)]
                    for n in tree.nodes if n.bl_idname == "ShaderNodeMapRange")
    return [links, grids, named, ranges]
"""


@pytest.mark.parametrize(
    ("with_ao", "shading"), [(True, "AMBIENT"), (True, "ALBEDO"), (False, "AMBIENT")]
)
def test_load_series_plays_the_frames_as_one_animated_volume(
    extension: Path, tmp_path: Path, openvdb, with_ao: bool, shading: str
) -> None:
    count = 4
    manifest = make_series(tmp_path / "series", count=count, with_ao=with_ao)
    result, output = blender(
        extension,
        tmp_path / "user",
        CAMERA_AND_WORLD
        + WIRING
        + f"""
s = scene.occlux
s.ao_shading, s.ao_factor = {shading!r}, 0.6
scene.frame_start, scene.frame_end = 10, 250  # the series starts at the scene's first frame
before = set(bpy.data.objects)
s.series_path = {str(manifest)!r}
result["op"] = attempt(bpy.ops.occlux.import_series)
added = [o for o in bpy.data.objects if o not in before]
result["added"] = [o.name for o in added]
obj = added[0]
data = obj.data
result["sequence"] = [obj.type, data.is_sequence, data.frame_duration, data.frame_start,
                      data.frame_offset, data.sequence_mode]
result["render"] = [data.render.precision, data.render.clipping]
result["range"] = [scene.frame_start, scene.frame_end]
result["active"] = bpy.context.view_layer.objects.active == obj and obj.select_get()
result["marks"] = sorted(obj.keys())
frames = {{}}
for f in (9, 10, 11, 10 + {count} - 1, 10 + {count}):
    scene.frame_set(f)
    loaded = data.grids.load()
    evaluated = obj.evaluated_get(bpy.context.evaluated_depsgraph_get())
    corners = [list(c) for c in evaluated.bound_box]
    size = max(c[0] for c in corners) - min(c[0] for c in corners)
    frames[f] = [loaded, data.grids.frame, data.grids.frame_filepath,
                 sorted(g.name for g in data.grids), round(size, 4)]
result["frames"] = frames
result["wiring"] = wiring(obj)
def counts():
    occlux_materials = sum(m.name.startswith("Occlux") for m in bpy.data.materials)
    return [len(bpy.data.objects), len(bpy.data.volumes), occlux_materials]
result["counts"] = counts()

# Again, through a frame's VDB: the same object shows the series, nothing else is added.
scene.frame_set(1)
result["again"] = attempt(bpy.ops.occlux.import_series,
                          filepath={str(manifest.parent / "series_0002.vdb")!r})
# And as the panel's button runs it (invoke): the panel's Series, here a frame's VDB.
s.series_path = {str(manifest.parent / "series_0003.vdb")!r}
result["invoked"] = sorted(bpy.ops.occlux.import_series("INVOKE_DEFAULT"))
result["same_object"] = bpy.data.objects.get("series") == obj and obj.data.is_sequence
result["counts_again"] = counts()

# What Load Volume, and Compute AO, make of the first frame's source: the series' material
# is that of a single volume, AO-shaded as Compute AO shades it.
s.volume_path = {str(manifest.parent / "step_01.npy")!r}
s.output_dir = {str(tmp_path / "out") + "/"!r}
s.preset, s.ao_method, s.ao_radius, s.device = {PRESET!r}, "cdf", 4, "cpu"
op = bpy.ops.occlux.compute_ao if {with_ao!r} else bpy.ops.occlux.import_volume
result["single"] = attempt(op)
result["series_untouched"] = obj.data.is_sequence and obj.name == "series"
result["single_wiring"] = wiring(bpy.data.objects["step_01"])
""",
    )
    assert result["op"] == ["FINISHED"], output
    assert result["added"] == ["series"], "one object for the whole series"
    assert result["sequence"] == ["VOLUME", True, count, 10, 0, "CLIP"], result["sequence"]
    assert result["render"] == ["FULL", 0.0], "a single volume's precision and clipping"
    assert result["range"] == [10, 10 + count - 1], "the scene's range is the series'"
    assert f"scene frames set to 10-{10 + count - 1}" in output, "the report says so"
    assert result["active"] and result["marks"] == ["occlux_series"], result
    frames = {int(f): v for f, v in result["frames"].items()}
    grids = sorted(["density", "value"] + ["ao"] * with_ao)
    sizes, voxels = [], []
    for k, f in enumerate((10, 11, 10 + count - 1)):
        number = (1, 2, count)[k]
        loaded, frame, path, names, size = frames[f]
        assert loaded and frame == number, frames[f]
        assert Path(path).name == f"series_{number:04d}.vdb", frames[f]
        assert Path(path).parent == manifest.parent, frames[f]
        assert names == grids, frames[f]
        sizes.append(size)
        voxels.append(openvdb.read(path, "value").activeVoxelCount())
    # Each frame is its own time: the file Blender loads holds the sphere at that frame.
    assert voxels[0] < voxels[1] < voxels[2], voxels
    if not with_ao:  # (openness is 1 outside the sphere: an `ao` grid spans the volume)
        assert sizes[0] < sizes[1] < sizes[2], f"Blender's bounds grow with the sphere: {sizes}"
    for f in (9, 10 + count):  # CLIP: nothing outside the series' frames
        loaded, _, path, names, size = frames[f]
        assert loaded and path == "" and names == [] and size == 0.0, frames[f]

    _, attributes, named, _ = result["wiring"]
    if with_ao:
        assert attributes == ["ao", "value"] and ["Occlux AO factor", 0.6] in named, named
        assert ("Occlux ambient light" in [n[0] for n in named]) == (shading == "AMBIENT")
    else:
        assert attributes == ["value"] and named == [], result["wiring"]
    assert result["single"] == ["FINISHED"] and result["series_untouched"], output
    # The same wiring as Load Volume's material, or Compute AO's; the transfer function on the
    # series' window (fixed across the frames: the manifest's raw points), not frame 1's own.
    assert result["wiring"][:3] == result["single_wiring"][:3], (
        result["wiring"],
        result["single_wiring"],
    )
    values = [p[0] for p in json.loads(manifest.read_text())["raw_points"]]
    assert result["wiring"][3] and all(
        r == [round(min(values), 4), round(max(values), 4)] for r in result["wiring"][3]
    ), (result["wiring"][3], values)

    assert result["again"] == result["invoked"] == ["FINISHED"], output
    assert result["same_object"], "the object that shows the series shows it again"
    # The camera and the series; one volume and one Occlux material: the old ones released.
    counts, again = result["counts"], result["counts_again"]
    assert again == counts == [2, 1, 1], (counts, again)


def test_load_series_reports_bad_input_and_adds_nothing(extension: Path, tmp_path: Path) -> None:
    """A missing or unset manifest, a VDB without a manifest beside it, a file that is not JSON,
    an unknown version, a frame whose VDB is missing (named), no VDB at all (run without
    export), frames Blender would not play in order, and a first VDB Blender cannot read: each
    a clear error, nothing added, the scene's range and the series' files as they were."""
    cases: dict[str, Path] = {}

    def variant(name: str, edit=None) -> Path:
        manifest = make_series(tmp_path / name, count=3, with_ao=False)
        if edit is not None:
            tree = json.loads(manifest.read_text())
            edit(tree, manifest.parent)
            manifest.write_text(json.dumps(tree))
        cases[name] = manifest
        return manifest

    def no_vdbs(tree: dict, folder: Path) -> None:
        for frame in tree["frames"]:
            frame["vdb"] = None

    variant("version", lambda tree, folder: tree.update(occlux_series=2))
    variant("missing_frame", lambda tree, folder: (folder / "series_0002.vdb").unlink())
    variant("no_vdbs", no_vdbs)

    def swapped(tree: dict, folder: Path) -> None:
        second, third = tree["frames"][1:3]
        second["vdb"], third["vdb"] = third["vdb"], second["vdb"]

    variant("order", swapped)
    variant("unreadable", lambda tree, folder: (folder / "series_0001.vdb").write_text("no"))
    bad_json = variant("json")
    bad_json.write_text('{"occlux_series": 1, "frames": [')
    alone = tmp_path / "alone"
    alone.mkdir()
    (alone / "lone_0001.vdb").write_bytes((tmp_path / "json" / "series_0001.vdb").read_bytes())
    paths = {name: str(path) for name, path in cases.items()}
    paths["missing"] = str(tmp_path / "nowhere.series.json")
    paths["vdb_alone"] = str(alone / "lone_0001.vdb")
    paths["unset"] = ""
    files_before = sorted(str(p) for p in tmp_path.rglob("*"))
    result, output = blender(
        extension,
        tmp_path / "user",
        f"""
scene = bpy.context.scene
KINDS = ("objects", "volumes", "materials", "worlds", "node_groups")
def counts():
    return [len(getattr(bpy.data, kind)) for kind in KINDS] + [scene.frame_end]
before = counts()
outcomes = {{}}
for case, path in {paths!r}.items():
    scene.occlux.series_path = path
    outcomes[case] = attempt(bpy.ops.occlux.import_series)
result["outcomes"] = outcomes
result["unchanged"] = counts() == before
""",
    )
    outcomes = result["outcomes"]
    assert all(isinstance(o, str) for o in outcomes.values()), outcomes  # each an error
    assert "no series manifest at" in outcomes["missing"], outcomes["missing"]
    assert "nowhere.series.json" in outcomes["missing"], outcomes["missing"]
    assert "no series file set (Occlux panel > Series)" in outcomes["unset"], outcomes
    assert "no series manifest lone.series.json beside lone_0001.vdb" in outcomes["vdb_alone"]
    assert "not valid JSON" in outcomes["json"], outcomes["json"]
    assert "unknown occlux_series version 2" in outcomes["version"], outcomes["version"]
    assert "missing frame VDB series_0002.vdb (frame 2)" in outcomes["missing_frame"], outcomes
    assert "no VDB for any frame" in outcomes["no_vdbs"], outcomes["no_vdbs"]
    assert "run without VDB export" in outcomes["no_vdbs"], outcomes["no_vdbs"]
    assert "Blender plays series_0002.vdb there" in outcomes["order"], outcomes["order"]
    unreadable = outcomes["unreadable"]
    assert "Blender cannot read" in unreadable and "series_0001.vdb" in unreadable, unreadable
    assert result["unchanged"], output
    assert sorted(str(p) for p in tmp_path.rglob("*") if "user" not in p.parts) == [
        f for f in files_before if "user" not in Path(f).parts
    ], "the series' files are left as they were"


def test_the_panel_shows_the_series_path_and_load_series(extension: Path, tmp_path: Path) -> None:
    result, _ = blender(
        extension,
        tmp_path,
        """
from types import SimpleNamespace
drawn = []
class Layout:  # records what the panel draws
    def __getattr__(self, name):
        return lambda *args, **kwargs: self
    def prop(self, data, name, **kwargs):
        drawn.append(name)
    def operator(self, idname, **kwargs):
        drawn.append(idname)
        return SimpleNamespace()
bpy.types.VIEW3D_PT_occlux.draw(SimpleNamespace(layout=Layout()), bpy.context)
result["drawn"] = drawn
result["property"] = bpy.context.scene.occlux.bl_rna.properties["series_path"].subtype
result["label"] = bpy.types.OCCLUX_OT_import_series.bl_label
result["options"] = sorted(bpy.types.OCCLUX_OT_import_series.bl_options)
""",
    )
    drawn = result["drawn"]
    # Beside Load Volume: the Series path, then its button.
    at = drawn.index("occlux.import_volume")
    assert drawn[at + 1 : at + 3] == ["series_path", "occlux.import_series"], drawn
    assert result["property"] == "FILE_PATH" and result["label"] == "Load Series"
    assert result["options"] == ["REGISTER", "UNDO"], result
