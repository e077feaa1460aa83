"""The friction a new user met in the add-on (issue 39, item 6), each fixed and tested headless:
AO shading Off, the `shadow` layer refused onto a render that holds the lamps' shadows, VDBs
named by their settings, the output folder of an unsaved file, Compute AO on the panel's
Volume, the raw loader's messages in the panel's words, EEVEE's clamp of indirect light in
volumes, grids stored at the precision they need, and docs/blender.md's five steps on
Blender's factory scene."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import occlux
import pytest
from occlux_testing import oiio_read
from test_addon import CAMERA_AND_WORLD, SHARED, SUN, blender, phantom_npy

# A VDB the add-on names by its settings: STEM-HASH.vdb, or STEM-KIND-HASH.vdb.
HASH = "[0-9a-f]{12}"


def vdb_name(stem: str, kind: str = "") -> re.Pattern:
    return re.compile(rf"{stem}-{kind + '-' if kind else ''}{HASH}\.vdb")


# The panel drawn into a recording layout: the labels it shows and the operators' texts.
DRAWN_LABELS = """
from types import SimpleNamespace
def drawn():
    shown = {"labels": [], "ops": {}}
    class Layout:
        def __getattr__(self, name):  # column, box, separator, progress
            return lambda *args, **kwargs: self
        def label(self, text="", **kwargs):
            shown["labels"].append(text)
        def operator(self, idname, text=None, **kwargs):
            shown["ops"][idname] = text
            return SimpleNamespace()
    bpy.types.VIEW3D_PT_occlux.draw(SimpleNamespace(layout=Layout()), bpy.context)
    return shown
"""


def test_ao_shading_off_gives_back_the_plain_material_and_the_world(
    extension: Path, tmp_path: Path
) -> None:
    """AO strength 0 under Ambient light still emits the world's light (unoccluded) while the
    world lights camera rays only; AO shading Off gives the volume Load Volume's plain material
    (no `ao` attribute, no ambient emission) on the same object, from Load Volume's own VDB,
    and lets the world light every ray again. The panel's button then says Turn AO Off."""
    result, output = blender(
        extension,
        tmp_path / "user",
        CAMERA_AND_WORLD
        + DRAWN_LABELS
        + f"""
s = scene.occlux
s.volume_path = {str(phantom_npy(tmp_path))!r}
s.preset, s.device, s.output_dir = "ct-soft-tissue", "cpu", {str(tmp_path / "out") + "/"!r}
s.ao_method, s.ao_radius = "cdf", 2
bpy.ops.occlux.import_volume()
obj = bpy.context.view_layer.objects.active
plain_vdb = obj.data.filepath
def state():
    nodes = obj.active_material.node_tree.nodes
    mix = scene.world.node_tree.nodes.get("Occlux world for camera rays only")
    return {{
        "attributes": sorted(
            n.attribute_name for n in nodes if n.bl_idname == "ShaderNodeAttribute"),
        "ambient": "Occlux ambient light" in nodes,
        "camera_only": mix is not None and bool(mix.inputs["Fac"].links),
        "vdb_is_plain": obj.data.filepath == plain_vdb,
    }}
result["ambient"] = [attempt(bpy.ops.occlux.compute_ao), state()]
s.ao_factor = 0.0
result["strength_0"] = state()
s.ao_shading = "OFF"
result["button"] = drawn()["ops"]["occlux.compute_ao"]
result["off"] = [attempt(bpy.ops.occlux.compute_ao), state(), s.status]
result["same_object"] = bpy.context.view_layer.objects.active == obj
result["volumes"] = sum(o.type == "VOLUME" for o in bpy.data.objects)
""",
    )
    outcome, ambient = result["ambient"]
    assert outcome == ["FINISHED"], output
    assert ambient["ambient"] and ambient["camera_only"] and "ao" in ambient["attributes"]
    # Strength 0 is not off: the world's light is still emitted, the world gated to camera rays.
    assert result["strength_0"]["ambient"] and result["strength_0"]["camera_only"]
    outcome, off, status = result["off"]
    assert outcome == ["FINISHED"], output
    assert off == {
        "attributes": ["value"],
        "ambient": False,
        "camera_only": False,
        "vdb_is_plain": True,
    }, off
    assert status.startswith("AO off: 'phantom' shows phantom.npy unshaded"), status
    assert result["same_object"] and result["volumes"] == 1
    assert result["button"] == "Turn AO Off"


def ipsvi_exr(path: Path) -> Path:
    """An IPSVI render of a sphere under a sun, with its `beauty` and `shadow` layers."""
    scene = occlux.Scene.from_toml(
        '[volume]\nphantom = "sphere"\nsize = 16\n'
        "[camera]\nposition = [3, -3, 2]\nwidth = 32\nheight = 24\n"
        '[[lights]]\ntype = "directional"\ndirection = [0, 0, 1]\nirradiance = 3.0\n'
        '[render]\nmethod = "ipsvi"\n'
    )
    occlux.write_exr(path, occlux.render(scene, device="cpu"), scene)
    return path


def test_the_shadow_layer_is_refused_onto_a_render_that_holds_the_shadows(
    extension: Path, tmp_path: Path
) -> None:
    """IPSVI's `shadow` layer onto a render whose sun casts shadows (Cycles; EEVEE with volume
    shadows) would darken it twice: refused, naming the lamp, with no compositor group made. A
    render without them (the sun's Cast Shadow off, or EEVEE without volume shadows) takes it,
    and the `beauty` layer (Mix) always."""
    exr = ipsvi_exr(tmp_path / "sphere-ipsvi.exr")
    result, output = blender(
        extension,
        tmp_path / "user",
        CAMERA_AND_WORLD
        + SUN
        + f"""
composite = lambda **kw: attempt(bpy.ops.occlux.composite, filepath={str(exr)!r}, **kw)
outcomes = {{}}
scene.render.engine = "CYCLES"
outcomes["cycles"] = [composite(layer="shadow"), len(bpy.data.node_groups)]
outcomes["cycles beauty"] = composite(layer="beauty", blend="MIX")
scene.render.engine = "BLENDER_EEVEE"
scene.eevee.use_volumetric_shadows = True
outcomes["eevee shadows"] = composite(layer="shadow")
scene.eevee.use_volumetric_shadows = False
outcomes["eevee no shadows"] = composite(layer="shadow")
scene.render.engine = "CYCLES"
sun.data.use_shadow = False
outcomes["cycles no cast shadow"] = composite(layer="shadow")
result["outcomes"] = outcomes
""",
    )
    outcomes = result["outcomes"]
    refused, groups = outcomes["cycles"]
    assert "already holds the shadows of lamp 'Sun'" in refused, refused
    assert "apply them twice" in refused and groups == 0, refused
    assert "already holds the shadows of lamp 'Sun'" in outcomes["eevee shadows"], outcomes
    for case in ("cycles beauty", "eevee no shadows", "cycles no cast shadow"):
        assert outcomes[case] == ["FINISHED"], (case, outcomes, output)


def test_vdbs_are_named_by_their_settings_and_the_panels_volume_is_the_one_computed(
    extension: Path, tmp_path: Path
) -> None:
    """Loading the same file with another preset, AO by another method, a bake with other
    settings: each writes its own file, so the files an earlier .blend renders stay as they
    were. Compute AO with a file typed into the panel's Volume while another Occlux volume is
    active computes that file's AO, on that file's object, and leaves the active one alone."""
    other = tmp_path / "other.npy"
    np.save(other, np.asarray(occlux.Volume.phantom("ct", 48).values))
    out = tmp_path / "out"
    result, output = blender(
        extension,
        tmp_path / "user",
        CAMERA_AND_WORLD
        + SUN
        + f"""
import hashlib, os
from pathlib import Path
scene.render.resolution_x, scene.render.resolution_y = 32, 24
s = scene.occlux
s.volume_path = {str(phantom_npy(tmp_path))!r}
s.preset, s.device, s.output_dir = "ct-soft-tissue", "cpu", {str(out) + "/"!r}
s.ao_radius, s.bake_multiple = 2, False
digest = lambda path: hashlib.sha256(Path(path).read_bytes()).hexdigest()
def written(op):
    before = set(os.listdir({str(out)!r})) if os.path.isdir({str(out)!r}) else set()
    outcome = attempt(op)
    return [outcome, sorted(set(os.listdir({str(out)!r})) - before)]
names = {{}}
names["load"] = written(bpy.ops.occlux.import_volume)
first = bpy.context.view_layer.objects.active.data.filepath
first_digest = digest(first)
s.preset = "ct-bone"
names["load other preset"] = written(bpy.ops.occlux.import_volume)
names["load again"] = written(bpy.ops.occlux.import_volume)
s.ao_method = "cdf"
names["ao cdf"] = written(bpy.ops.occlux.compute_ao)
s.ao_method = "gauss"
names["ao gauss"] = written(bpy.ops.occlux.compute_ao)
names["bake"] = written(bpy.ops.occlux.bake_light)
s.ipsvi_g = 0.5
names["bake other g"] = written(bpy.ops.occlux.bake_light)
result["names"] = names
result["first_kept"] = digest(first) == first_digest

# The panel's Volume changed while the phantom is active: Compute AO acts on the new file.
phantom = bpy.context.view_layer.objects.active
phantom_vdb = phantom.data.filepath
s.volume_path = {str(other)!r}
s.ao_method = "cdf"
result["other"] = attempt(bpy.ops.occlux.compute_ao)
active = bpy.context.view_layer.objects.active
result["other_status"] = s.status
result["active"] = active.name
result["other_grids"] = sorted(g.name for g in active.data.grids)
result["phantom_kept"] = phantom.data.filepath == phantom_vdb
# With the Volume field empty, the active Occlux volume's file, as before.
s.volume_path = ""
bpy.context.view_layer.objects.active = phantom
result["active_only"] = [attempt(bpy.ops.occlux.compute_ao), s.status]
""",
    )
    names = result["names"]
    for step in names.values():
        assert step[0] == ["FINISHED"], (names, output)

    def one(step: str, pattern: re.Pattern) -> bool:
        """The step wrote one new file, named as `pattern` says."""
        return len(names[step][1]) == 1 and bool(pattern.fullmatch(names[step][1][0]))

    assert one("load", vdb_name("phantom")) and one("load other preset", vdb_name("phantom"))
    assert names["load again"][1] == [], "the same settings: the same file, rewritten"
    assert one("ao cdf", vdb_name("phantom", "ao")) and one("ao gauss", vdb_name("phantom", "ao"))
    bake = vdb_name("phantom", "bake")
    assert one("bake", bake) and one("bake other g", bake)
    assert result["first_kept"], "the first load's grids are untouched"

    assert result["other"] == ["FINISHED"], output
    assert result["active"] == "other" and "ao" in result["other_grids"], result
    assert "the active 'phantom' is left as it was" in result["other_status"], result
    assert result["phantom_kept"], result
    outcome, status = result["active_only"]
    assert outcome == ["FINISHED"] and status.startswith("AO (cdf, radius 2) of phantom.npy")


def test_an_unsaved_file_says_where_its_output_goes(
    extension: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """An unsaved .blend writes `//occlux/` into the temporary folder: the panel shows that
    folder under Output and the operator's report names it; once the .blend is saved the output
    goes beside it and neither says so."""
    temporary = tmp_path / "tmp"
    temporary.mkdir()
    (tmp_path / "saved").mkdir()
    monkeypatch.setenv("TMPDIR", str(temporary))  # Blender's tempfile.gettempdir()
    result, output = blender(
        extension,
        tmp_path / "user",
        CAMERA_AND_WORLD
        + DRAWN_LABELS
        + f"""
s = scene.occlux
s.volume_path = {str(phantom_npy(tmp_path))!r}
s.preset, s.device = "ct-soft-tissue", "cpu"
result["unsaved"] = [attempt(bpy.ops.occlux.import_volume), s.status, drawn()["labels"],
                     bpy.context.view_layer.objects.active.data.filepath]
bpy.ops.wm.save_as_mainfile(filepath={str(tmp_path / "saved" / "scene.blend")!r})
result["saved"] = [attempt(bpy.ops.occlux.import_volume), s.status, drawn()["labels"],
                   bpy.context.view_layer.objects.active.data.filepath]
""",
    )
    folder = temporary / "occlux"
    outcome, status, labels, vdb = result["unsaved"]
    assert outcome == ["FINISHED"], output
    said = f"the .blend file is unsaved: Output //occlux/ is {folder}"
    assert status.endswith(f"({said})"), status
    assert said[0].upper() + said[1:] in labels, labels
    assert Path(vdb).parent == folder and Path(vdb).is_file(), vdb
    outcome, status, labels, vdb = result["saved"]
    assert outcome == ["FINISHED"] and "is unsaved" not in status, status
    assert not any("is unsaved" in label for label in labels), labels
    assert Path(vdb).parent == tmp_path / "saved" / "occlux", vdb


def test_raw_file_messages_say_what_the_panel_can_change(extension: Path, tmp_path: Path) -> None:
    """A raw file shorter than its dims and type need is too small, a longer one too large (by
    how much), with no scene key named; a NaN voxel is refused without naming the scene key
    the panel has no field for, saying what to do instead."""
    side = 16
    need = side**3
    (tmp_path / "short.raw").write_bytes(bytes(100))
    (tmp_path / "long.raw").write_bytes(bytes(need + 100))
    values = np.zeros(need, dtype=np.float32)
    values[5] = np.nan
    (tmp_path / "nan.raw").write_bytes(values.tobytes())
    result, _ = blender(
        extension,
        tmp_path / "user",
        f"""
s = bpy.context.scene.occlux
s.output_dir = {str(tmp_path / "out") + "/"!r}
s.raw_dims = ({side}, {side}, {side})
messages = {{}}
for name, kind in (("short", "uint8"), ("long", "uint8"), ("nan", "float32")):
    s.volume_path, s.raw_type = {str(tmp_path)!r} + f"/{{name}}.raw", kind
    messages[name] = attempt(bpy.ops.occlux.import_volume)
result["messages"] = messages
""",
    )
    messages = result["messages"]
    short, long, nan = messages["short"], messages["long"], messages["nan"]
    assert "short.raw" in short and "file is 100 bytes, too small" in short, short
    assert f"{side}x{side}x{side} uint8 ({need} bytes of voxels) need {need}" in short, short
    assert "long.raw" in long and f"file is {need + 100} bytes, too large" in long, long
    assert "100 fewer" in long, long
    for message in messages.values():
        assert "header_bytes" not in message and "volume.raw" not in message, message
    assert "nan.raw" in nan and "NaN" in nan and "replace_non_finite" not in nan.split("CLI")[0]
    assert "the Occlux panel has no replacement for them" in nan, nan


def test_load_volume_unclamps_eevees_volume_light_and_restore_puts_it_back(
    extension: Path, tmp_path: Path
) -> None:
    """EEVEE's factory scene clamps the indirect light in volumes to 1e-8, which turns the
    world's light on a plain volume black: Load Volume sets it to 0 (no clamp) and says so, and
    Restore EEVEE Settings puts the factory value back; loading again changes nothing more."""
    result, output = blender(
        extension,
        tmp_path / "user",
        f"""
scene = bpy.context.scene
s = scene.occlux
s.volume_path = {str(phantom_npy(tmp_path))!r}
s.preset, s.device, s.output_dir = "ct-soft-tissue", "cpu", {str(tmp_path / "out") + "/"!r}
result["factory"] = scene.eevee.clamp_volume_indirect
result["load"] = [attempt(bpy.ops.occlux.import_volume), s.status,
                  scene.eevee.clamp_volume_indirect]
result["again"] = [attempt(bpy.ops.occlux.import_volume), s.status]
result["restore"] = [attempt(bpy.ops.occlux.restore_eevee), scene.eevee.clamp_volume_indirect,
                     "occlux_eevee_before" in scene]
""",
    )
    assert result["factory"] == pytest.approx(1e-8), "the factory clamp this test is about"
    outcome, status, clamp = result["load"]
    assert outcome == ["FINISHED"] and clamp == 0.0, output
    assert (
        "set EEVEE clamp_volume_indirect 1e-08 -> 0 (the world lights volumes in EEVEE)" in status
    )
    outcome, status = result["again"]
    assert outcome == ["FINISHED"] and "EEVEE" not in status, status
    outcome, clamp, saved = result["restore"]
    assert outcome == ["FINISHED"] and clamp == pytest.approx(1e-8) and not saved, result


def test_grids_are_stored_at_the_precision_their_values_need(
    extension: Path, tmp_path: Path, openvdb
) -> None:
    """An 8-bit scan's VDBs: `value` as half floats (its integers exactly), `ao` as half floats
    (within 2^-11 of the float32 grid), `density` as float32, zlib on; Compute AO's file is at
    least 1.4 times smaller than the same grids all in float32 (measured 1.6 on this phantom's
    sweep-physical AO)."""
    scan = np.asarray(occlux.Volume.phantom("ct", 64).values)
    quantised = np.round(255.0 * (scan - scan.min()) / np.ptp(scan)).astype(np.uint8)
    raw = tmp_path / "scan.raw"
    raw.write_bytes(quantised.tobytes())  # (z, y, x) C order: x fastest, as raw files are
    out = tmp_path / "out"
    result, output = blender(
        extension,
        tmp_path / "user",
        f"""
s = bpy.context.scene.occlux
s.volume_path = {str(raw)!r}
s.raw_dims, s.raw_type = (64, 64, 64), "uint8"
s.preset, s.device, s.output_dir = "ct-soft-tissue", "cpu", {str(out) + "/"!r}
s.ao_method = "sweep-physical"
result["load"] = attempt(bpy.ops.occlux.import_volume)
result["ao"] = attempt(bpy.ops.occlux.compute_ao)
obj = bpy.context.view_layer.objects.active
result["vdb"] = obj.data.filepath
result["blender_grids"] = sorted(g.name for g in obj.data.grids)
""",
    )
    assert result["load"] == ["FINISHED"] and result["ao"] == ["FINISHED"], output
    vdb = Path(result["vdb"])
    assert result["blender_grids"] == ["ao", "density", "value"], "Blender reads the half grids"
    grids = {name: openvdb.read(str(vdb), name) for name in ("density", "value", "ao")}
    half = {name: grid.saveFloatAsHalf for name, grid in grids.items()}
    assert half == {"density": False, "value": True, "ao": True}, half

    def dense(name: str) -> np.ndarray:
        got = np.zeros((64, 64, 64), dtype=np.float32)  # x, y, z
        grids[name].copyToArray(got, ijk=(0, 0, 0))
        return got.transpose(2, 1, 0)

    np.testing.assert_array_equal(dense("value"), quantised.astype(np.float32))
    # The same grids in float32, computed here: the file the writer wrote before.
    fitted = occlux.Volume(quantised.astype(np.float32), spacing=(2.0 / 64,) * 3)
    scene = occlux.Scene.from_dict(
        {"volume": {"phantom": "sphere"}, "camera": {"position": [0, -4, 0]}}
    )
    scene.classification = occlux.Classification.preset("ct-soft-tissue")
    ao = occlux.ao_volume(scene, method="sweep-physical", device="cpu", volume=fitted)["ao"]
    np.testing.assert_allclose(dense("ao"), ao.values, rtol=2.0**-11, atol=1e-6)
    full = tmp_path / "float32.vdb"
    density = scene.classification.extinction(fitted)
    occlux.write_vdb(full, {"density": density, "value": fitted, "ao": ao}, half=False)
    np.testing.assert_allclose(dense("density"), density.values, rtol=1e-6)
    factor = full.stat().st_size / vdb.stat().st_size
    print(f"float32 {full.stat().st_size} bytes, stored {vdb.stat().st_size} bytes: {factor:.2f}x")
    assert factor > 1.4, factor


def test_the_guides_five_steps_work_as_written_on_the_factory_scene(
    extension: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """docs/blender.md's "The first figure in five steps", on Blender's factory scene (its Cube,
    Light and Camera; unsaved, so Output `//occlux/` is the temporary folder), at 10 % of the
    factory render size: the volume loads, its AO shades it, the factory camera at 90 mm (the
    guide's lens at 16:9) frames it, a sun of strength 3.5 lights it, Cycles renders it, Render
    DOS and Render IPSVI write their layers, and Composite takes DOS's `occlusion` layer while
    it refuses IPSVI's `shadow` onto Cycles' render under a shadowing sun, as the guide says."""
    monkeypatch.setenv("TMPDIR", str(tmp_path))
    figure = tmp_path / "render.png"
    result, output = blender(
        extension,
        tmp_path / "user",
        f"""
import os
scene = bpy.context.scene
result["factory"] = sorted(o.name for o in bpy.data.objects)
s = scene.occlux
# 1. Pick the volume.
s.volume_path, s.preset = {str(SHARED / "tooth.nrrd")!r}, "ct-soft-tissue"
# 2. Load it.
result["load"] = attempt(bpy.ops.occlux.import_volume)
obj = bpy.context.view_layer.objects.active
result["loaded"] = [obj.name, sorted(g.name for g in obj.data.grids)]
# 3. Compute AO (the default method and shading).
result["ao"] = [attempt(bpy.ops.occlux.compute_ao), s.ao_method, s.ao_shading]
result["ao_object"] = [bpy.context.view_layer.objects.active == obj,
                       sorted(g.name for g in obj.data.grids)]
# 4. Light and frame it.
bpy.data.objects.remove(bpy.data.objects["Cube"])
scene.camera.data.lens = 90  # the guide's lens at the factory's 16:9 size
scene.world.node_tree.nodes["Background"].inputs["Color"].default_value = (0.3, 0.35, 0.45, 1)
key = bpy.data.objects["Light"].data
key.type, key.energy = "SUN", 3.5
# 5. Render: F12 with Cycles, then Render DOS, Render IPSVI and Composite.
scene.render.engine = "CYCLES"
scene.cycles.samples = 8
scene.render.resolution_percentage = 10
scene.render.filepath = {str(figure)!r}
result["render"] = sorted(bpy.ops.render.render(write_still=True))
result["dos"] = [attempt(bpy.ops.occlux.render_dos), s.last_exr, s.status]
result["ipsvi"] = [attempt(bpy.ops.occlux.render_ipsvi), s.last_exr]
dos_exr, ipsvi_exr = result["dos"][1], result["ipsvi"][1]
result["shadow"] = attempt(bpy.ops.occlux.composite, filepath=ipsvi_exr, layer="shadow")
result["occlusion"] = attempt(bpy.ops.occlux.composite, filepath=dos_exr, layer="occlusion")
result["objects"] = sorted(o.name for o in bpy.data.objects)
""",
    )
    assert result["factory"] == ["Camera", "Cube", "Light"], result
    assert result["load"] == ["FINISHED"], output
    assert result["loaded"] == ["tooth", ["density", "value"]], result
    assert result["ao"] == [["FINISHED"], "ordinates", "AMBIENT"], output
    assert result["ao_object"] == [True, ["ao", "density", "value"]], result
    assert result["render"] == ["FINISHED"], output
    assert result["dos"][0] == ["FINISHED"] and "left out light 'Light'" in result["dos"][2]
    assert Path(result["dos"][1]).name == "tooth-dos.exr", result["dos"]
    assert result["ipsvi"][0] == ["FINISHED"], output
    assert Path(result["ipsvi"][1]).name == "tooth-ipsvi.exr", result["ipsvi"]
    assert Path(result["ipsvi"][1]).parent == tmp_path / "occlux", "unsaved: the temporary folder"
    assert "apply them twice" in result["shadow"], result["shadow"]
    assert result["occlusion"] == ["FINISHED"], output
    assert result["objects"] == ["Camera", "Light", "tooth"]
    # The factory camera at 90 mm frames the tooth, lit, not burnt white: it covers part of the
    # frame, not all of it.
    pixels = oiio_read(figure)
    assert pixels["R"].shape == (108, 192), pixels["R"].shape
    rgb = np.stack([pixels[c] for c in "RGB"], axis=-1)
    sky = np.median(rgb[:5, :5].reshape(-1, 3), axis=0)
    tooth = np.abs(rgb - sky).max(axis=-1) > 0.05
    assert 0.02 < tooth.mean() < 0.6, tooth.mean()
    grey = rgb[tooth].mean(axis=-1)
    assert np.median(grey) < 0.95 and grey.std() > 0.02, "lit, with shading, not burnt white"
    rows, cols = np.nonzero(tooth)
    assert 20 < rows.mean() < 88 and 40 < cols.mean() < 152, "near the frame's centre"
