"""Bake Light in the Blender extension, headless (bpy in a subprocess, the extension built,
installed and enabled as in test_addon.py): the scene's light baked into the volume's grids and
a material that emits it, rendered by Cycles and EEVEE against Cycles' path-traced truth of the
same Blender scene, and what the bake changes in the scene (light linking, the world, EEVEE's
settings, the drivers that keep strengths and colours live).

The truth is the volume with its plain material (Load Volume's) lit by Cycles itself: under
the sun with 8 volume bounces (the bake holds the sun's single and multiple scattering), under
the world alone with none (the bake's `ao` is the world's single scattering)."""

from __future__ import annotations

from pathlib import Path

import pytest
from test_addon import CAMERA_AND_WORLD, SUN, blender, phantom_npy

SIZE = (64, 48)
TRUTH_SPP, TRUTH_SEEDS = 256, 8


def bake_script(tmp_path: Path, lighting: str) -> str:
    world_strength = 0.0 if lighting == "sun" else 1.0
    lamps = "" if lighting == "world" else SUN
    return (
        CAMERA_AND_WORLD
        + lamps
        + f"""
import json
import time
from pathlib import Path
check_baked = sys.modules["bl_ext.user_default.occlux.operators.check_baked"]
background.inputs["Strength"].default_value = {world_strength}
scene.render.resolution_x, scene.render.resolution_y = {SIZE}
s = scene.occlux
s.volume_path = {str(phantom_npy(tmp_path))!r}
s.preset, s.device, s.output_dir = "ct-soft-tissue", "cpu", {str(tmp_path / "out") + "/"!r}
result["load"] = list(bpy.ops.occlux.import_volume())
obj = bpy.context.view_layer.objects.active
started = time.perf_counter()
result["bake"] = list(bpy.ops.occlux.bake_light())
result["bake_s"] = time.perf_counter() - started
result["grids"] = sorted(obj.data.grids.keys())
result["volume_biased"] = scene.cycles.volume_biased
result["eevee_settings"] = [scene.eevee.volumetric_tile_size, scene.eevee.volumetric_samples]
s.check_subject, s.check_engine, s.check_engine_samples = "BAKED", "EEVEE", 16
s.check_size, s.check_spp, s.check_seeds = {max(SIZE)}, {TRUTH_SPP}, {TRUTH_SEEDS}
result["check"] = list(bpy.ops.occlux.check_cycles())
result["status"] = s.status
result["report"] = json.loads(open(s.check_report).read())
result["panel"] = [s.check_rel_rmse, s.check_bias, s.check_checked]
result["scenes"] = [x.name for x in bpy.data.scenes]
# Cycles with the bake, against the check's truth.
for spp in (1, 4, 16):
    figures = check_baked.against_checked_truth(scene, obj, Path(s.check_report), "CYCLES", spp)
    result[f"cycles_{{spp}}"] = [figures["rel_rmse"], figures["bias"], figures["seconds"]]
"""
    )


@pytest.mark.parametrize("lighting", ["sun", "world", "both"])
def test_bake_light_renders_in_cycles_and_eevee_what_cycles_path_traces(
    extension: Path, tmp_path: Path, lighting: str
) -> None:
    """Check Against Cycles of the baked scene: EEVEE (through the operator) and Cycles at 1, 4
    and 16 samples with the bake, against Cycles' path-traced truth of the same Blender scene
    rendered by the check (the volume's plain material, 8 volume bounces; the bake holds the
    world's and the sun's multiple scattering). Cycles with the bake traces no light in the
    volume (it only absorbs and emits), so one sample is near its converged image; EEVEE's
    froxels (1 pixel, 256 slices, set by the bake) blur the baked light along and across the
    view. Measured on this phantom (relative RMSE, bias; the truth's noise):
    - sun: EEVEE 0.062 (-1.2 %), Cycles 0.055 / 0.054 / 0.054 (-0.4 %); noise 0.050;
    - world: EEVEE 0.038 (-0.2 %), Cycles 0.037 (+0.4 %) at every count; noise 0.035;
    - both: EEVEE 0.032 (-0.5 %), Cycles 0.031 (+0.2 %); noise 0.028
    (without the world's multiple scattering in the bake, both was -39 %). The bounds below add
    the truth's noise to the issue's goals."""
    result, output = blender(extension, tmp_path / "user", bake_script(tmp_path, lighting))
    print({k: v for k, v in result.items() if k != "report"}, result["report"])
    assert result["load"] == ["FINISHED"] and result["bake"] == ["FINISHED"], output
    assert result["check"] == ["FINISHED"], result["status"]
    lamp_grids = ["light0", "light0_multiple_b", "light0_multiple_g", "light0_multiple_r"]
    world_grids = ["ao", "ao_multiple_b", "ao_multiple_g", "ao_multiple_r"]
    wanted = sorted(
        ["density", "value"] + world_grids + ([] if lighting == "world" else lamp_grids)
    )
    assert result["grids"] == wanted, result["grids"]
    assert result["volume_biased"], result
    # 64 x 48 pixels: 1-pixel froxels fit the froxel budget.
    assert result["eevee_settings"] == ["1", 256], result
    report = result["report"]
    assert report["engine"] == "EEVEE" and report["engine_samples"] == 16, report
    assert report["truth"]["bounces"] == 8, report
    assert report["size"] == list(SIZE) and report["pixels"] > 500, report
    assert report["cycles_scene"]["lamps"] == ([] if lighting == "world" else ["Sun"]), report
    rel, bias, checked = result["panel"]
    assert rel == pytest.approx(report["rel_rmse"], rel=1e-5) and checked == "Eevee 16 spp"
    assert result["scenes"] == ["Scene"], result
    noise = report["noise"]
    assert noise < 0.08, report
    goal = 0.08 if lighting == "world" else 0.10
    assert report["rel_rmse"] <= goal + noise and abs(report["bias"]) <= 0.05, report
    rmse, bias, _ = result["cycles_4"]
    assert rmse <= 0.05 + noise and abs(bias) <= 0.03, result


def test_bake_light_keeps_strengths_live_and_says_when_to_bake_again(
    extension: Path, tmp_path: Path
) -> None:
    """What a bake changes in the scene and what it leaves live: the sun no longer lights the
    volume (light linking), the world lights only camera rays, the material's colour nodes
    follow the sun's strength and colour and the world's without a new bake, a moved sun is
    reported, Restore EEVEE Settings undoes the bake's settings, and a scaled volume object is
    refused with nothing changed."""
    result, output = blender(
        extension,
        tmp_path / "user",
        CAMERA_AND_WORLD
        + SUN
        + f"""
bake = sys.modules["bl_ext.user_default.occlux.operators.bake"]
scene.render.resolution_x, scene.render.resolution_y = 32, 24
s = scene.occlux
s.volume_path = {str(phantom_npy(tmp_path))!r}
s.preset, s.device, s.output_dir = "ct-soft-tissue", "cpu", {str(tmp_path / "out") + "/"!r}
s.bake_multiple = False
bpy.ops.occlux.import_volume()
obj = bpy.context.view_layer.objects.active
tile_before = scene.eevee.volumetric_tile_size
obj.scale = (2.0, 2.0, 2.0)
result["scaled"] = attempt(bpy.ops.occlux.bake_light)
result["scaled_mark"] = "occlux_bake" in obj
obj.scale = (1.0, 1.0, 1.0)
result["bake"] = attempt(bpy.ops.occlux.bake_light)
collection = sun.light_linking.receiver_collection
result["linked"] = [(m.name, c.light_linking.link_state)
                    for m, c in zip(collection.objects, collection.collection_objects)]
result["world"] = sorted(n.name for n in scene.world.node_tree.nodes)
nodes = obj.active_material.node_tree.nodes
def colours():
    bpy.context.view_layer.update()
    return [list(nodes["Occlux baked light Sun"].outputs[0].default_value)[:3],
            list(nodes["Occlux baked world light"].outputs[0].default_value)[:3]]
result["colours"] = colours()
sun.data.energy, sun.data.color = 6.0, (0.5, 1.0, 1.0)
background.inputs["Strength"].default_value = 2.0
result["changed"] = colours()
result["outdated"] = bake.outdated(bpy.context, obj)
sun.rotation_quaternion = Vector((0.3, -1.0, 1.2)).to_track_quat("Z", "Y")
bpy.context.view_layer.update()
result["moved"] = bake.outdated(bpy.context, obj)
result["tile"] = scene.eevee.volumetric_tile_size
result["restore"] = attempt(bpy.ops.occlux.restore_eevee)
result["restored"] = scene.eevee.volumetric_tile_size == tile_before
""",
    )
    assert "unscaled" in result["scaled"] and not result["scaled_mark"], result
    assert result["bake"] == ["FINISHED"], output
    assert result["linked"] == [["phantom", "EXCLUDE"]], result
    assert "Occlux world for camera rays only" in result["world"], result
    sun, world = result["colours"]
    assert sun == pytest.approx([3.0, 2.85, 2.7]) and world == pytest.approx([1.0, 0.9, 0.8])
    sun, world = result["changed"]
    assert sun == pytest.approx([3.0, 6.0, 6.0]) and world == pytest.approx([2.0, 1.8, 1.6])
    assert result["outdated"] == "" and result["moved"] == "lamp 'Sun' moved", result
    assert result["tile"] == "1" and result["restore"] == ["FINISHED"] and result["restored"]


def test_the_ambient_ao_material_follows_the_world_set_after_compute_ao(
    extension: Path, tmp_path: Path
) -> None:
    """The guide's order (Compute AO, then the world's colour): the material's ambient light is
    the world's as it renders, not as it was when AO was computed; the Cycles check's copy
    without AO keeps it black."""
    result, output = blender(
        extension,
        tmp_path / "user",
        CAMERA_AND_WORLD
        + f"""
material = sys.modules["bl_ext.user_default.occlux.material"]
s = scene.occlux
s.volume_path = {str(phantom_npy(tmp_path))!r}
s.preset, s.device, s.output_dir = "ct-soft-tissue", "cpu", {str(tmp_path / "out") + "/"!r}
s.ao_shading = "AMBIENT"
background.inputs["Color"].default_value = (0.05, 0.05, 0.05, 1.0)
result["op"] = list(bpy.ops.occlux.compute_ao())
shading = bpy.context.view_layer.objects.active.active_material
background.inputs["Color"].default_value = (0.6, 0.5, 0.4, 1.0)
background.inputs["Strength"].default_value = 2.0
bpy.context.view_layer.update()
node = shading.node_tree.nodes[material.AMBIENT]
result["ambient"] = list(node.outputs[0].default_value)[:3]
truth = shading.copy()
material.without_ao(truth, 0.0)
bpy.context.view_layer.update()
result["truth"] = list(truth.node_tree.nodes[material.AMBIENT].outputs[0].default_value)[:3]
""",
    )
    assert result["op"] == ["FINISHED"], output
    assert result["ambient"] == pytest.approx([1.2, 1.0, 0.8]), result
    assert result["truth"] == [0.0, 0.0, 0.0], result
