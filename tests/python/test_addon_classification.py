"""The panel's transfer function in the Blender extension, headless (bpy in a subprocess, the
extension built, installed and enabled as in test_addon.py): the ramp on a window of the file's
values, Suggest from File (the core's robust window and `occlux info --suggest`'s ramp), the
histogram the Volume object keeps, Apply Classification, and refusals that change nothing.

The volume is the 64^3 CT phantom saved as .npy: its values are the file's, as the core reads
them (fitted to 2 units, no value changed)."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import occlux
import pytest
from test_addon import SHARED, blender, phantom_npy

GUIDE = Path(__file__).resolve().parents[2] / "docs" / "blender.md"

# What a script reads of the add-on's own modules.
MODULES = """
import sys
addon = "bl_ext.user_default.occlux"
transfer = sys.modules[addon + ".transfer"]
bake = sys.modules[addon + ".operators.bake"]
"""


def settings(tmp_path: Path) -> str:
    """The panel's Volume (the phantom), the CPU and an output folder in `tmp_path`."""
    return f"""
s = bpy.context.scene.occlux
s.volume_path = {str(phantom_npy(tmp_path))!r}
s.device, s.output_dir = "cpu", {str(tmp_path / "out") + "/"!r}
"""


def phantom() -> np.ndarray:
    return np.asarray(occlux.Volume.phantom("ct", 64).values)


def density(openvdb, vdb: str) -> np.ndarray:
    """The `density` grid of a VDB the add-on wrote, as (z, y, x)."""
    got = np.zeros((64, 64, 64), dtype=np.float32)  # x, y, z
    openvdb.read(vdb, "density").copyToArray(got, ijk=(0, 0, 0))
    return got.transpose(2, 1, 0)


def ramp_extinction(values: np.ndarray, ramp: list, window: tuple, top: float) -> np.ndarray:
    """The extinction of the panel's ramp (position, alpha) on the window (lo, hi), evaluated
    exactly: linear between the stops, constant beyond them."""
    lo, hi = window
    raw = [lo + p * (hi - lo) for p, _ in ramp]
    return np.interp(values.astype(np.float64), raw, [a * top for _, a in ramp])


def test_suggest_from_file_gives_the_cores_robust_window_and_ramp_and_the_histogram(
    extension: Path, tmp_path: Path
) -> None:
    result, output = blender(
        extension,
        tmp_path / "user",
        MODULES
        + settings(tmp_path)
        + """
def ramp():
    node = transfer.ramp_node(s)
    return [[e.position, list(e.color)] for e in node.color_ramp.elements]
result["load"] = attempt(bpy.ops.occlux.import_volume)  # the preset: kept over the robust window
obj = bpy.context.view_layer.objects.active
result["kept"] = json.loads(obj[transfer.CLASSIFIED])
result["icon"] = transfer.histogram_icon(obj)  # 0 headless: Blender makes no icons
counts = result["kept"]["histogram"]["counts"]
result["picture"] = transfer.histogram_pixels(counts, 64, 64)
s.transfer = "RAMP"  # the first ramp: suggested on the window the active volume keeps
result["chosen"] = [s.window_lo, s.window_hi, s.use_window_cut, s.max_density, ramp()]
# Without an object that keeps it, Suggest from File reads the file.
bpy.data.objects.remove(obj)
s.window_lo, s.window_hi, s.max_density = 0.0, 1.0, 1.0
result["suggest"] = attempt(bpy.ops.occlux.suggest_classification)
result["suggested"] = [s.window_lo, s.window_hi, s.use_window_cut, s.max_density, ramp()]
result["section"] = transfer.section(s)
""",
    )
    assert result["load"] == ["FINISHED"] and result["suggest"] == ["FINISHED"], output
    values = phantom()
    robust = occlux.Volume(values).robust_window()
    lo, hi = robust["lo"], robust["hi"]
    kept = result["kept"]
    assert kept["classification"] == {"preset": "ct-bone", "density_scale": 1.0}
    assert kept["robust"]["lo"] == lo and kept["robust"]["hi"] == hi, kept["robust"]
    # The histogram the object keeps is numpy's of the file's values over the window.
    histogram = kept["histogram"]
    assert (histogram["lo"], histogram["hi"]) == (lo, hi)
    want, _ = np.histogram(values.astype(np.float64), bins=64, range=(lo, hi))
    np.testing.assert_array_equal(histogram["counts"], want)
    # The panel's picture: a column per bin, the fullest bin's bar the picture's height.
    assert isinstance(result["icon"], int)
    picture = np.array(result["picture"]).reshape(64, 64, 4)  # rows bottom up, RGBA
    bars = (picture[..., 0] > 0.5).sum(axis=0)
    assert bars[int(np.argmax(want))] == 64 and np.all(bars[want == 0] == 0)
    assert np.all(np.diff(bars[np.argsort(want, kind="stable")]) >= 0), "taller for more"
    # Both ways to the suggestion give the core's window and `occlux info --suggest`'s ramp:
    # positions on the window, RGB the albedo, alpha the extinction over the densest point.
    top = max(p[1] for p in robust["points"])
    stops = [((p[0] - lo) / (hi - lo), [*p[2], p[1] / top]) for p in robust["points"]]
    for chosen in (result["chosen"], result["suggested"]):
        assert chosen[:4] == pytest.approx([lo, hi, False, top], rel=1e-6)
        assert len(chosen[4]) == len(stops)
        for (position, rgba), (want_position, want_rgba) in zip(chosen[4], stops, strict=True):
            assert position == pytest.approx(want_position, abs=1e-6)
            assert rgba == pytest.approx(want_rgba, abs=1e-6)
    # The core gets the stops as normalised points on the window.
    section = result["section"]
    assert section["range"] == pytest.approx({"lo": lo, "hi": hi})
    assert [p["sigma_t"] for p in section["points"]] == pytest.approx(
        [p[1] for p in robust["points"]], rel=1e-6
    )


def test_a_ramp_edit_changes_the_grids_and_the_material_together(
    extension: Path, tmp_path: Path, openvdb
) -> None:
    result, output = blender(
        extension,
        tmp_path / "user",
        MODULES
        + settings(tmp_path)
        + """
def state():
    ramp = transfer.ramp_node(s).color_ramp
    tree = obj.data.materials[0].node_tree
    # The material's optics ramp: alpha = sigma_t / its largest, mapped from its raw values.
    optics = next(n for n in tree.nodes if n.bl_idname == "ShaderNodeValToRGB")
    to_unit = next(n for n in tree.nodes if n.bl_idname == "ShaderNodeMapRange")
    return {
        "vdb": obj.data.filepath,
        "ramp": [[e.position, e.alpha] for e in ramp.elements],
        "window": [s.window_lo, s.window_hi],
        "top": s.max_density,
        "material": [[e.position, e.alpha] for e in optics.color_ramp.elements],
        "material_range": [to_unit.inputs["From Min"].default_value,
                           to_unit.inputs["From Max"].default_value],
    }
s.transfer = "RAMP"
result["suggest"] = attempt(bpy.ops.occlux.suggest_classification)
result["load"] = attempt(bpy.ops.occlux.import_volume)
obj = bpy.context.view_layer.objects.active
result["before"] = state()
# Edit the ramp as the panel's widget does: a denser middle, half the window's top.
ramp = transfer.ramp_node(s).color_ramp
ramp.elements[1].alpha = 1.0
ramp.elements[2].alpha = 0.5
s.window_hi = s.window_hi * 1.2
import sys
panel = sys.modules[addon + ".panel"]
result["due"] = panel.classification_due(bpy.context, obj)
result["apply"] = attempt(bpy.ops.occlux.apply_classification)
result["after"] = state()
result["due_after"] = panel.classification_due(bpy.context, obj)
""",
    )
    assert result["suggest"] == ["FINISHED"] and result["load"] == ["FINISHED"], output
    assert result["apply"] == ["FINISHED"], output
    assert "Apply Classification" in result["due"] and result["due_after"] == ""
    before, after = result["before"], result["after"]
    assert before["vdb"] != after["vdb"], "another classification, another file"
    values = phantom()
    for state in (before, after):
        want = ramp_extinction(values, state["ramp"], state["window"], state["top"])
        got = density(openvdb, state["vdb"])
        # Occlux's table is linear between 4096 entries over the window: within 1 % of the top.
        np.testing.assert_allclose(got, want, atol=0.01 * state["top"])
        # The material holds the same function (the core's raw points): its stops on the
        # file's values from the first stop's to the last's, alpha over the densest.
        lo, hi = state["window"]
        raw = [lo + p * (hi - lo) for p, _ in state["ramp"]]
        assert state["material_range"] == pytest.approx([raw[0], raw[-1]], rel=1e-5)
        densest = max(a for _, a in state["ramp"])
        for (p, a), v, (_, want_a) in zip(state["material"], raw, state["ramp"], strict=True):
            assert p == pytest.approx((v - raw[0]) / (raw[-1] - raw[0]), abs=1e-5)
            assert a == pytest.approx(want_a / densest, abs=1e-5)
    assert not np.allclose(density(openvdb, before["vdb"]), density(openvdb, after["vdb"]))


def test_apply_bakes_a_baked_volume_again_after_a_ramp_edit(
    extension: Path, tmp_path: Path
) -> None:
    result, output = blender(
        extension,
        tmp_path / "user",
        MODULES
        + settings(tmp_path)
        + """
scene = bpy.context.scene
bpy.ops.object.light_add(type="SUN", location=(0, 0, 3))
scene.world.node_tree.nodes["Background"].inputs["Strength"].default_value = 1.0
s.bake_multiple = False  # the single-scattered light is enough to see the re-bake
s.transfer = "RAMP"
result["suggest"] = attempt(bpy.ops.occlux.suggest_classification)
result["load"] = attempt(bpy.ops.occlux.import_volume)
obj = bpy.context.view_layer.objects.active
result["bake"] = attempt(bpy.ops.occlux.bake_light)
result["baked"] = obj.data.filepath
transfer.ramp_node(s).color_ramp.elements[1].alpha = 0.9
result["outdated"] = bake.outdated(bpy.context, obj)
result["apply"] = attempt(bpy.ops.occlux.apply_classification)
result["rebaked"] = obj.data.filepath
result["outdated_after"] = bake.outdated(bpy.context, obj)
result["fingerprint"] = json.loads(obj[bake.BAKED])["classification"]
result["section"] = transfer.section(s)
""",
    )
    assert result["load"] == ["FINISHED"] and result["bake"] == ["FINISHED"], output
    assert result["outdated"] == "the volume or its classification changed"
    assert result["apply"] == ["FINISHED"], output
    assert "-bake-" in Path(result["rebaked"]).name and result["rebaked"] != result["baked"]
    assert result["outdated_after"] == "" and result["fingerprint"] == result["section"]


def test_a_bad_window_or_a_missing_ramp_is_refused_by_name_with_nothing_changed(
    extension: Path, tmp_path: Path
) -> None:
    result, output = blender(
        extension,
        tmp_path / "user",
        MODULES
        + settings(tmp_path)
        + """
KINDS = ("objects", "volumes", "materials", "node_groups")
def state():
    obj = bpy.context.view_layer.objects.active
    return [{k: len(getattr(bpy.data, k)) for k in KINDS}, obj.data.filepath,
            obj[transfer.CLASSIFIED]]
s.transfer = "RAMP"
result["suggest"] = attempt(bpy.ops.occlux.suggest_classification)
result["load"] = attempt(bpy.ops.occlux.import_volume)
before = state()
hi = s.window_hi
s.window_lo = hi  # lo >= hi
result["equal"] = [attempt(bpy.ops.occlux.apply_classification),
                   attempt(bpy.ops.occlux.import_volume), attempt(bpy.ops.occlux.compute_ao)]
result["equal_same"] = state() == before
s.window_lo = 0.0
s.use_window_cut, s.window_cut = True, hi - 1.0  # a cut below the top
result["cut"] = attempt(bpy.ops.occlux.apply_classification)
s.use_window_cut = False
bpy.data.node_groups.remove(s.ramp)  # no ramp left
result["no_ramp"] = [attempt(bpy.ops.occlux.apply_classification),
                     attempt(bpy.ops.occlux.bake_light)]
result["no_ramp_same"] = state()[1:] == before[1:]
result["outdated"] = bake.outdated(bpy.context, bpy.context.view_layer.objects.active)
""",
    )
    assert result["suggest"] == ["FINISHED"] and result["load"] == ["FINISHED"], output
    for refused in result["equal"]:
        assert "the window's Low" in refused and "must be below its High" in refused, refused
    assert result["equal_same"], "nothing added, the object shows what it showed"
    assert "the window's Cut" in result["cut"] and "above its High" in result["cut"]
    for refused in result["no_ramp"]:
        assert "the transfer function has no ramp" in refused, refused
    assert result["no_ramp_same"] and result["outdated"] == ""


def test_the_guides_classification_script_runs(extension: Path, tmp_path: Path) -> None:
    """docs/blender.md's script of "Classify from the panel", verbatim, in a folder that holds
    tooth.nrrd: the ramp edit reaches the volume's grids (another VDB, the panel's
    classification kept on the object)."""
    tooth = SHARED / "tooth.nrrd"
    assert tooth.is_file(), f"{tooth} is missing: CI runs with ../shared beside the project"
    section = GUIDE.read_text().split("## Classify from the panel", 1)[1].split("\n## ", 1)[0]
    (script,) = re.findall(r"```python\n(.*?)```", section, flags=re.DOTALL)
    folder = tmp_path / "work"
    folder.mkdir()
    (folder / "tooth.nrrd").symlink_to(tooth)
    result, output = blender(
        extension,
        tmp_path / "user",
        f"""
import os
os.chdir({str(folder)!r})
bpy.context.scene.occlux.output_dir = {str(tmp_path / "out") + "/"!r}
"""
        + script
        + MODULES
        + """
obj = bpy.data.objects["tooth"]
result["kept"] = json.loads(obj[transfer.CLASSIFIED])["classification"]
result["section"] = transfer.section(s)
result["vdbs"] = sorted(os.listdir(s.output_dir))
""",
    )
    assert "window " in output and result["kept"] == result["section"], output
    assert result["section"]["points"][1]["sigma_t"] == pytest.approx(0.4 * 20.0, rel=1e-6)
    assert len(result["vdbs"]) == 2, "the preset's grids, then the ramp's"
