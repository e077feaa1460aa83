"""The Blender extension, headless: built with Blender's extension tool, installed and enabled in
a throw-away user folder, its operators run on small volumes (a 64^3 phantom and tooth.nrrd),
and the outcome checked: objects, grids, material links, compositor nodes, files, and clear
errors that add nothing.

Each test runs Blender (bpy) in a subprocess, so the user folder and the extension's own copy
of the `occlux` wheel are used rather than this test process's."""

from __future__ import annotations

import ast
import io
import json
import os
import re
import subprocess
import sys
import textwrap
import zipfile
from pathlib import Path

import numpy as np
import occlux
import occlux.blender as ob
import pytest
from occlux_testing import REPO, oiio_read

SHARED = REPO.parent / "shared" / "data" / "scivis"
RESULT = "OCCLUX-RESULT "
# Compute AO's VDB of the tooth: named by its settings (SHA-256, 12 hex digits).
AO_VDB = re.compile(r"tooth-ao-[0-9a-f]{12}\.vdb")
# A scene for occlux.ao_volume, which reads only its classification.
AO_SCENE = {"volume": {"phantom": "sphere"}, "camera": {"position": [0, -4, 0]}}

# An operator that reports an error raises RuntimeError with the report when called from
# Python: `attempt` records either the operator's result or that message.
# Installs and enables the extension in the user folder, hiding the developer's editable
# `occlux` so that the extension's bundled wheel is what gets imported.
PRELUDE = """
import sys
sys.path = [p for p in sys.path if not p.rstrip("/").endswith("plugin/python")]
import json, bpy, addon_utils
assert bpy.ops.extensions.package_install_files(
    filepath=ZIP, repo="user_default", enable_on_install=True) == {"FINISHED"}
import occlux
result = {"occlux_from": occlux.__file__}
def done():
    print("OCCLUX-RESULT " + json.dumps(result))
def attempt(op, **kwargs):
    try:
        return sorted(op(**kwargs))
    except RuntimeError as e:
        return str(e)
"""


def blender(extension: Path, user: Path, script: str) -> tuple[dict, str]:
    """Runs `script` after the prelude in a fresh bpy process; returns its `result` and output."""
    env = {**os.environ, "BLENDER_USER_RESOURCES": str(user)}
    code = f"ZIP = {str(extension)!r}\n" + PRELUDE + textwrap.dedent(script) + "\ndone()\n"
    run = subprocess.run(
        [sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=300
    )
    output = run.stdout + run.stderr
    assert run.returncode == 0, output
    line = next(x for x in output.splitlines() if x.startswith(RESULT))
    return json.loads(line[len(RESULT) :]), output


# The sides of the volume's box as its material masks the density to it (where Occlux's medium
# ends; Blender's own bounds follow the grids' 8^3 leaves, padding included).
MASK_SIDES = """
def mask_sides(obj):
    tree = obj.data.materials[0].node_tree
    half = next(n for n in tree.nodes
                if n.bl_idname == "ShaderNodeVectorMath" and n.operation == "DIVIDE")
    return [2 * x for x in half.inputs[1].default_value]
"""


# A camera looking at the origin from where the example scenes look, and a uniform world.
CAMERA_AND_WORLD = """
from mathutils import Vector
scene = bpy.context.scene
for o in list(bpy.data.objects):
    bpy.data.objects.remove(o)
camera = bpy.data.objects.new("Camera", bpy.data.cameras.new("Camera"))
scene.collection.objects.link(camera)
camera.location = (3.2, -3.2, 2.6)
camera.rotation_mode = "QUATERNION"
camera.rotation_quaternion = (-camera.location).to_track_quat("-Z", "Y")
scene.camera = camera
camera.data.lens = 80  # the volume fills most of the frame
scene.render.resolution_x, scene.render.resolution_y = 400, 300
scene.world = scene.world or bpy.data.worlds.new("World")
background = next(n for n in scene.world.node_tree.nodes if n.bl_idname == "ShaderNodeBackground")
background.inputs["Color"].default_value = (1.0, 0.9, 0.8, 1.0)
background.inputs["Strength"].default_value = 1.0
"""


def phantom_npy(folder: Path) -> Path:
    path = folder / "phantom.npy"
    np.save(path, np.asarray(occlux.Volume.phantom("ct", 64).values))
    return path


def test_the_extension_installs_registers_and_reloads(extension: Path, tmp_path: Path) -> None:
    result, _ = blender(
        extension,
        tmp_path,
        """
        ops = ("import_volume", "compute_ao", "bake_light", "restore_eevee", "render_dos",
               "render_ipsvi", "check_cycles", "composite", "import_stage", "import_series",
               "suggest_classification", "apply_classification")
        result["registered"] = [hasattr(bpy.ops.occlux, op) for op in ops]
        result["panel"] = hasattr(bpy.types, "VIEW3D_PT_occlux")
        result["settings"] = hasattr(bpy.types.Scene, "occlux")
        name = "bl_ext.user_default.occlux"
        for _ in range(2):
            addon_utils.disable(name, default_set=True)
            result["after_disable"] = hasattr(bpy.types.Scene, "occlux")
            addon_utils.enable(name, default_set=True)
        result["after_reload"] = hasattr(bpy.ops.occlux, "import_volume")

        # The panel, drawn into a recording layout: every setting and operator it shows exists
        # (Blender itself only prints a warning for a misspelt one).
        from types import SimpleNamespace
        drawn = {"props": [], "ops": []}
        class Layout:
            def __getattr__(self, name):  # column, box, separator, label, progress
                return lambda *args, **kwargs: self
            def prop(self, data, name, **kwargs):
                drawn["props"].append(name)
            def operator(self, idname, **kwargs):
                drawn["ops"].append(idname)
                return SimpleNamespace()
        s = bpy.context.scene.occlux
        s.volume_path, s.status, s.check_report = "scan.raw", "done", "report.json"
        bpy.types.VIEW3D_PT_occlux.draw(SimpleNamespace(layout=Layout()), bpy.context)
        known = set(s.bl_rna.properties.keys())
        result["unknown_props"] = [p for p in drawn["props"] if p not in known]
        result["unknown_ops"] = [
            o for o in drawn["ops"] if not hasattr(bpy.ops.occlux, o.split(".")[1])]
        result["drawn"] = len(drawn["props"]), sorted(drawn["ops"])
        # The transfer function's Ramp: its window, Max density and Suggest from File too.
        drawn["props"], drawn["ops"] = [], []
        s.transfer = "RAMP"
        bpy.types.VIEW3D_PT_occlux.draw(SimpleNamespace(layout=Layout()), bpy.context)
        result["unknown_props"] += [p for p in drawn["props"] if p not in known]
        result["ramp_drawn"] = drawn["props"], drawn["ops"]
        """,
    )
    assert result["registered"] == [True] * 12 and result["panel"] and result["settings"]
    assert result["after_disable"] is False and result["after_reload"] is True
    assert result["unknown_props"] == [] and result["unknown_ops"] == [], result
    assert result["drawn"][0] > 20 and result["drawn"][1] == sorted(
        f"occlux.{op}"
        for op in (
            "import_volume", "compute_ao", "bake_light", "render_dos", "render_ipsvi",
            "check_cycles", "composite",
            "import_stage",
            "import_series",
            "apply_classification",
        )
    ), result["drawn"]  # fmt: skip
    ramp_props, ramp_ops = result["ramp_drawn"]
    assert {"window_lo", "window_hi", "window_cut", "max_density"} <= set(ramp_props)
    assert "preset" not in ramp_props and "occlux.suggest_classification" in ramp_ops
    # The occlux package came from the wheel inside the extension, not from this checkout.
    assert str(tmp_path) in result["occlux_from"], result["occlux_from"]


def imported_modules(path: Path) -> set[str]:
    """The absolute modules a Python file imports (relative imports left out)."""
    names = set()
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Import):
            names.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            names.add(node.module)
    return names


def test_user_code_imports_nothing_of_the_harness() -> None:
    """The add-on and the package users install import nothing of the measurement harness
    (`occlux_lab`, in lab/python, which neither ships), and every `occlux` module the add-on
    imports is in the package (plugin/python) or is its native module."""
    package = REPO / "plugin" / "python"
    addon = sorted((REPO / "blender_addon").rglob("*.py"))
    for path in [*addon, *sorted(package.rglob("*.py"))]:
        harness = [m for m in imported_modules(path) if m.split(".")[0] == "occlux_lab"]
        assert harness == [], f"{path} imports {harness}"
    for path in addon:
        for name in imported_modules(path):
            if name.split(".")[0] != "occlux" or name == "occlux._occlux":
                continue
            module = package.joinpath(*name.split("."))
            found = module.with_suffix(".py").is_file() or (module / "__init__.py").is_file()
            assert found, f"{path} imports {name}, which is not in {package}"


def test_the_bundled_wheel_holds_user_code_and_not_the_harness(extension: Path) -> None:
    """The `occlux` wheel inside the extension holds what users call (the native module, the
    Cycles mapping `occlux.blender` that the add-on's check and materials use, `occlux.usd`,
    `occlux.batch`) and none of the measurement harness (`occlux_lab`: the Cycles check's
    command line, the chart's curves and peers)."""
    with zipfile.ZipFile(extension) as z:
        (wheel,) = [n for n in z.namelist() if n.endswith(".whl")]
        names = zipfile.ZipFile(io.BytesIO(z.read(wheel))).namelist()
    for shipped in ("occlux/__init__.py", "occlux/batch.py", "occlux/usd.py"):
        assert shipped in names, names
    assert any(n.startswith("occlux/_occlux") for n in names), names
    blender = {n for n in names if n.startswith("occlux/blender/") and n.endswith(".py")}
    assert {"occlux/blender/__init__.py", "occlux/blender/material.py"} <= blender, names
    harness = [n for n in names if n.startswith(("occlux_lab/", "occlux/cycles/", "occlux/peers/"))]
    assert harness == [], harness


@pytest.mark.parametrize("source", ["phantom", "tooth"])
def test_load_volume_adds_a_classified_volume_object(
    extension: Path, tmp_path: Path, source: str
) -> None:
    if source == "phantom":
        path, preset = phantom_npy(tmp_path), "ct-soft-tissue"
    else:
        path, preset = SHARED / "tooth.nrrd", "ct-bone"
        assert path.is_file(), f"{path} is missing: CI runs with ../shared beside the project"
    result, output = blender(
        extension,
        tmp_path / "user",
        MASK_SIDES
        + textwrap.dedent(f"""
        s = bpy.context.scene.occlux
        s.volume_path = {str(path)!r}
        s.preset = {preset!r}
        s.output_dir = {str(tmp_path / "out") + "/"!r}
        result["op"] = list(bpy.ops.occlux.import_volume())
        obj = bpy.data.objects[{path.stem!r}]
        result["type"] = obj.type
        result["grids"] = sorted(g.name for g in obj.data.grids)
        result["filepath"] = obj.data.filepath
        result["size"] = max(mask_sides(obj))
        tree = obj.data.materials[0].node_tree
        shader = next(n for n in tree.nodes if n.bl_idname == "ShaderNodeVolumePrincipled")
        result["density_attribute"] = shader.inputs["Density Attribute"].default_value
        result["density_from"] = shader.inputs["Density"].links[0].from_node.bl_idname
        result["color_from"] = shader.inputs["Color"].links[0].from_node.bl_idname
        attrs = sorted(n.attribute_name for n in tree.nodes if n.bl_idname == "ShaderNodeAttribute")
        result["attributes"] = attrs
        """),
    )
    assert result["op"] == ["FINISHED"], output
    assert result["type"] == "VOLUME" and result["grids"] == ["density", "value"]
    assert Path(result["filepath"]).is_file()
    assert result["size"] == pytest.approx(2.0, abs=0.1), "fitted to 2 scene units"
    # sigma_t from the `value` grid through the points (the mapping occlux.blender renders),
    # so no grid multiplies it
    assert result["density_attribute"] == "" and result["density_from"] == "ShaderNodeMath"
    assert result["color_from"] == "ShaderNodeValToRGB" and result["attributes"] == ["value"]


def test_bad_input_reports_an_error_and_adds_nothing(extension: Path, tmp_path: Path) -> None:
    """Every volume operator, given a missing file, an unsupported format, a volume over the
    memory budget (refused by the core's loader from its header: the file holds no voxels), a
    short raw file, no camera, or cancelled mid-way: a clear message, and no new data-blocks or
    files."""
    (tmp_path / "notes.txt").write_text("not a volume")
    (tmp_path / "short.raw").write_bytes(bytes(100))
    (tmp_path / "huge.nrrd").write_text(
        "NRRD0004\ntype: float\ndimension: 3\nsizes: 4096 4096 4096\nendian: little\n"
        "encoding: raw\n\n"
    )
    out = tmp_path / "out"
    result, output = blender(
        extension,
        tmp_path / "user",
        CAMERA_AND_WORLD
        + f"""
import glob, tempfile
s = scene.occlux
s.output_dir = {str(out) + "/"!r}
KINDS = ("objects", "volumes", "materials", "images", "node_groups", "scenes", "worlds",
         "cameras", "lights")
def counts():
    return [len(getattr(bpy.data, kind)) for kind in KINDS]
checks = lambda: set(glob.glob(tempfile.gettempdir() + "/occlux-check-*"))
before, checks_before = counts(), checks()
outcomes = {{}}
for op in ("import_volume", "compute_ao", "render_dos", "check_cycles"):
    for case, path in (("missing", {str(tmp_path / "missing.nrrd")!r}),
                       ("unsupported", {str(tmp_path / "notes.txt")!r}),
                       ("short", {str(tmp_path / "short.raw")!r}),
                       ("huge", {str(tmp_path / "huge.nrrd")!r})):
        s.volume_path = path
        outcomes[op + " " + case] = attempt(getattr(bpy.ops.occlux, op))
    s.volume_path = ""
    outcomes[op + " unset"] = attempt(getattr(bpy.ops.occlux, op))
s.volume_path = {str(SHARED / "tooth.nrrd")!r}
s.memory_budget_mb = 5  # the tooth needs 5.9 MB as float32
outcomes["budget"] = attempt(bpy.ops.occlux.compute_ao)
s.memory_budget_mb = 2048
s.ao_method, s.ao_radius, s.device = "exact", 4, "cpu"
for op in ("compute_ao", "render_dos", "check_cycles"):
    outcomes[op + " cancel"] = [attempt(getattr(bpy.ops.occlux, op), cancel_after=2), s.status]
scene.camera = None
outcomes["no camera"] = attempt(bpy.ops.occlux.check_cycles)
outcomes["dos no camera"] = attempt(bpy.ops.occlux.render_dos)
result["outcomes"] = outcomes
result["unchanged"] = before == counts()
result["check_folders_left"] = sorted(checks() - checks_before)
x = {str(tmp_path / "x.exr")!r}
result["composite"] = attempt(bpy.ops.occlux.composite, filepath=x)
result["groups"] = len(bpy.data.node_groups)
""",
    )
    outcomes = result["outcomes"]
    for op in ("import_volume", "compute_ao", "render_dos", "check_cycles"):
        missing, unsupported = outcomes[f"{op} missing"], outcomes[f"{op} unsupported"]
        assert "no volume file" in missing and "missing.nrrd" in missing, missing
        unset = outcomes[f"{op} unset"]
        assert "no volume file set (Occlux panel > Volume)" in unset, unset
        assert "notes.txt" in unsupported, unsupported
        short = outcomes[f"{op} short"]  # the check's message is the core's loader's
        assert "short.raw" in short and "100 bytes" in short and "262144" in short, short
        huge = outcomes[f"{op} huge"]  # the core's message, and the panel's setting
        assert "huge.nrrd" in huge and "4096x4096x4096 need 256.0 GiB as f32" in huge, huge
        assert "more than the 2.0 GiB available" in huge, huge
        assert "Memory budget in the Occlux panel: 2048 MB" in huge, huge
    budget = outcomes["budget"]
    assert "tooth.nrrd" in budget and "available (volume.memory_budget_gib)" in budget, budget
    assert "Memory budget in the Occlux panel: 5 MB" in budget, budget
    labels = {"compute_ao": "Compute AO", "render_dos": "Render DOS"}
    for op, label in {**labels, "check_cycles": "Check Against Cycles"}.items():
        assert outcomes[f"{op} cancel"] == [["CANCELLED"], f"{label}: cancelled, nothing was added"]
    assert "no active camera" in outcomes["no camera"], outcomes["no camera"]
    assert "no active camera" in outcomes["dos no camera"], outcomes["dos no camera"]
    assert "no EXR file" in result["composite"]
    assert result["unchanged"] and result["groups"] == 0, output
    assert result["check_folders_left"] == [], "the check's temporary files are removed"
    assert not out.exists() or not any(out.iterdir()), sorted(out.iterdir())


def test_composite_builds_the_compositor_group(extension: Path, tmp_path: Path) -> None:
    scene = occlux.Scene.from_toml(
        '[volume]\nphantom = "sphere"\nsize = 16\n'
        "[camera]\nposition = [3, -3, 2]\nwidth = 32\nheight = 24\n"
    )
    exr = tmp_path / "sphere.exr"
    occlux.write_exr(exr, occlux.render(scene, device="cpu"), scene)
    result, output = blender(
        extension,
        tmp_path / "user",
        f"""
        op = bpy.ops.occlux.composite
        result["ok"] = list(op(filepath={str(exr)!r}, layer="beauty", blend="MIX"))
        tree = bpy.context.scene.compositing_node_group
        result["nodes"] = sorted(n.bl_idname for n in tree.nodes)
        image = next(n for n in tree.nodes if n.bl_idname == "CompositorNodeImage")
        result["image_to"] = image.outputs["beauty"].links[0].to_node.bl_idname
        result["bad"] = attempt(op, filepath={str(exr)!r}, layer="dos")
        result["groups"] = len(bpy.data.node_groups)
        """,
    )
    assert result["ok"] == ["FINISHED"], output
    assert result["nodes"] == [
        "CompositorNodeImage",
        "CompositorNodeRLayers",
        "NodeGroupOutput",
        "ShaderNodeMix",
    ]
    assert result["image_to"] == "ShaderNodeMix"
    assert "no layer 'dos'" in result["bad"], result["bad"]
    assert result["groups"] == 1, "the failed request left no node group behind"


@pytest.mark.parametrize(
    ("source", "method", "shading"),
    [("phantom", "cdf", "ALBEDO"), ("tooth", "gauss", "AMBIENT"), ("phantom", "sweep", "ALBEDO")],
)
def test_compute_ao_adds_a_volume_shaded_by_its_ao_grid(
    extension: Path, tmp_path: Path, openvdb, source: str, method: str, shading: str
) -> None:
    if source == "phantom":
        path, preset = phantom_npy(tmp_path), "ct-soft-tissue"
    else:
        path, preset = SHARED / "tooth.nrrd", "ct-bone"
    out = tmp_path / "out"
    result, output = blender(
        extension,
        tmp_path / "user",
        f"""
        s = bpy.context.scene.occlux
        s.volume_path = {str(path)!r}
        s.preset = {preset!r}
        s.output_dir = {str(out) + "/"!r}
        s.ao_method, s.ao_radius, s.ao_shading, s.device = {method!r}, 4, {shading!r}, "cpu"
        s.ao_factor, s.ao_gamma, s.ao_light = 0.7, 1.5, "sky"
        result["loaded"] = list(bpy.ops.occlux.import_volume())
        loaded = bpy.data.objects[{path.stem!r}]
        result["loaded_filepath"] = loaded.data.filepath
        loaded.location = (0.5, 0.0, 0.0)  # the user's placement, which AO keeps
        s.volume_path = ""  # AO acts on the active Occlux volume, not on the panel's path
        result["op"] = list(bpy.ops.occlux.compute_ao())
        obj = bpy.data.objects[{path.stem!r}]
        result["same_object"] = obj == loaded and list(obj.location) == [0.5, 0.0, 0.0]
        result["counts"] = [
            sum(o.type == "VOLUME" for o in bpy.data.objects),
            len(bpy.data.volumes),
            sum(m.name.startswith("Occlux") for m in bpy.data.materials),
        ]
        result["material"] = obj.data.materials[0].name
        result["grids"] = sorted(g.name for g in obj.data.grids)
        result["filepath"] = obj.data.filepath
        result["status"] = s.status
        tree = obj.data.materials[0].node_tree
        shader = next(n for n in tree.nodes if n.bl_idname == "ShaderNodeVolumePrincipled")
        ao = next(n for n in tree.nodes
                  if n.bl_idname == "ShaderNodeAttribute" and n.attribute_name == "ao")
        result["ao_to"] = [l.to_node.bl_idname for l in ao.outputs["Fac"].links]
        result["color_from"] = shader.inputs["Color"].links[0].from_node.bl_idname
        emission = shader.inputs["Emission Color"].links
        result["emission_from"] = emission[0].from_node.bl_idname if emission else None
        result["factor"] = tree.nodes["Occlux AO factor"].outputs[0].default_value
        s.ao_factor = 0.25  # the panel's slider moves the material's factor
        result["factor_after"] = tree.nodes["Occlux AO factor"].outputs[0].default_value
        def camera_only():
            mix = bpy.context.scene.world.node_tree.nodes.get("Occlux world for camera rays only")
            return mix is not None and bool(mix.inputs["Fac"].links)
        result["camera_only"] = camera_only()
        # The other shading: the world follows (AMBIENT's material carries the world's light).
        s.ao_shading = "ALBEDO" if s.ao_shading == "AMBIENT" else "AMBIENT"
        result["switched"] = list(bpy.ops.occlux.compute_ao())
        result["camera_only_switched"] = camera_only()
        """,
    )
    assert result["loaded"] == ["FINISHED"] and result["op"] == ["FINISHED"], output
    # One dataset, one object: its data and material replaced, nothing left of the old ones.
    assert result["same_object"] and result["counts"] == [1, 1, 1], result
    assert result["material"] == f"Occlux {path.stem}"
    sweep = method == "sweep"
    assert result["grids"] == ["ao", "density"] + ["sdf"] * sweep + ["value"]
    # Named by the file and its settings (STEM-HASH.vdb, STEM-ao-HASH.vdb): the AO of the
    # other shading is the same grid, in the same file.
    vdb, loaded_vdb = Path(result["filepath"]), Path(result["loaded_filepath"])
    assert vdb.parent == out and re.fullmatch(rf"{path.stem}-ao-[0-9a-f]{{12}}\.vdb", vdb.name)
    assert re.fullmatch(rf"{path.stem}-[0-9a-f]{{12}}\.vdb", loaded_vdb.name), loaded_vdb
    written = sorted(p.name for p in out.iterdir())
    assert written == sorted([vdb.name, loaded_vdb.name]), "no temporary left"
    assert "AO" in result["status"] and ("radius 4" in result["status"]) != sweep
    assert result["ao_to"] == ["ShaderNodeMix"]  # mix(1, ao, strength)
    if shading == "ALBEDO":  # the albedo darkened, no emission
        assert result["color_from"] == "ShaderNodeMix" and result["emission_from"] is None
    else:  # the albedo as classified, the ambient light it scatters emitted
        assert result["color_from"] == "ShaderNodeValToRGB"
        assert result["emission_from"] == "ShaderNodeMix"
    assert result["factor"] == pytest.approx(0.7) and result["factor_after"] == pytest.approx(0.25)
    ambient = shading == "AMBIENT"
    assert result["camera_only"] == ambient and result["switched"] == ["FINISHED"], result
    assert result["camera_only_switched"] != ambient, "the world lights the volume again"

    # The `ao` grid is what occlux.ao_volume computes for the fitted volume (2 units wide).
    volume = occlux.Volume.load(path)
    scale = 2.0 / max(np.array(volume.dims) * np.array(volume.spacing))
    fitted = occlux.Volume(volume.values, spacing=tuple(np.array(volume.spacing) * scale))
    scene = occlux.Scene.from_dict(AO_SCENE)
    scene.classification = occlux.Classification.preset(preset)
    # The sweep takes the panel's gamma and its sky (the four upper octants).
    options = {"gamma": 1.5, "octant_intensities": [1] * 4 + [0] * 4} if sweep else {"radius": 4}
    want = occlux.ao_volume(scene, method=method, device="cpu", volume=fitted, **options)["ao"]
    grid = openvdb.read(str(vdb), "ao")
    got = np.zeros(volume.dims, dtype=np.float32)  # x, y, z
    grid.copyToArray(got, ijk=(0, 0, 0))
    # Stored as half floats: within their rounding (2^-11 relative).
    np.testing.assert_allclose(got.transpose(2, 1, 0), want.values, rtol=2.0**-11, atol=1e-6)
    assert 0.0 <= want.values.min() < 0.9 and want.values.max() <= 1.0, "some voxels occluded"
    if not sweep:  # 1 = unoccluded, so the material leaves the open air and flat surfaces alone
        assert np.mean(want.values == 1.0) > 0.5, "VAO's raw 1/2 in empty air is not the grid"
    assert grid.transform.voxelSize()[0] == pytest.approx(scale * volume.spacing[0], rel=1e-5)


def test_jobs_run_on_a_thread_and_cancel_without_adding_anything(
    extension: Path, tmp_path: Path
) -> None:
    out = tmp_path / "out"
    result, output = blender(
        extension,
        tmp_path / "user",
        f"""
        import threading, time
        jobs = sys.modules["bl_ext.user_default.occlux.operators.jobs"]
        s = bpy.context.scene.occlux
        s.volume_path = {str(SHARED / "tooth.nrrd")!r}
        s.output_dir = {str(out) + "/"!r}
        s.ao_method, s.ao_radius, s.device = "exact", 6, "cpu"
        before = len(bpy.data.objects), len(bpy.data.volumes), len(bpy.data.materials)
        # ESC as the modal operator sees it: the progress callback answers False after two
        # reports, the core raises "cancelled", the operator reports and adds nothing.
        result["cancelled"] = attempt(bpy.ops.occlux.compute_ao, cancel_after=2)
        result["status"] = s.status
        result["unchanged"] = before == (
            len(bpy.data.objects), len(bpy.data.volumes), len(bpy.data.materials))
        # Without a window (headless) invoking runs the job synchronously.
        result["invoked"] = sorted(bpy.ops.occlux.compute_ao("INVOKE_DEFAULT"))

        # The modal path's thread: the main thread keeps running while the core computes,
        # then cancels it mid-way as ESC does.
        volume = occlux.Volume.load(s.volume_path)
        scene = occlux.Scene.from_dict({AO_SCENE!r})
        progress = jobs.JobProgress()
        work = lambda p: occlux.ao_volume(
            scene, method="exact", radius=6, device="cpu", volume=volume, progress=p)
        run = jobs.BackgroundRun(work, progress)
        result["other_thread"] = run.thread is not threading.current_thread()
        result["polled_while_running"] = bpy.types.OCCLUX_OT_compute_ao.poll(bpy.context)
        polls, cancelled_at = 0, None
        while run.running:
            polls += 1
            if cancelled_at is None and progress.fraction > 0.1:
                # What was done when ESC came (a later stage may restart its own fraction).
                cancelled_at = progress.fraction
                progress.cancel.set()
            time.sleep(0.01)
        result["polls"] = polls
        result["fraction"] = cancelled_at
        result["error"] = repr(run.error)
        result["active"] = len(jobs.ACTIVE)
        result["polled_after"] = bpy.types.OCCLUX_OT_compute_ao.poll(bpy.context)
        """,
    )
    assert result["cancelled"] == ["CANCELLED"], output
    assert "Compute AO: cancelled, nothing was added" in result["status"]
    assert "cancelled, nothing was added" in output, "the warning reaches the report area"
    assert result["unchanged"], "a cancelled job adds no object, volume or material"
    assert result["invoked"] == ["FINISHED"]
    written = [p.name for p in out.iterdir()]
    assert len(written) == 1 and AO_VDB.fullmatch(written[0]), "the cancel wrote nothing"
    assert result["other_thread"] and result["polls"] > 1
    assert result["polled_while_running"] is False, "one job at a time"
    assert result["fraction"] is not None and 0.1 < result["fraction"] < 1.0, result["fraction"]
    assert result["error"] == "OccluxError('cancelled')"
    assert result["active"] == 0 and result["polled_after"] is True


SUN = """
sun = bpy.data.objects.new("Sun", bpy.data.lights.new("Sun", "SUN"))
scene.collection.objects.link(sun)
sun.data.energy, sun.data.color, sun.data.angle = 3.0, (1.0, 0.95, 0.9), 0.0
sun.rotation_mode = "QUATERNION"
sun.rotation_quaternion = Vector((-0.3, -1.0, 1.2)).to_track_quat("Z", "Y")
"""


@pytest.mark.parametrize("estimator", ["ambient", "single"])
def test_check_against_cycles_agrees_and_reports_beside_the_blend_file(
    extension: Path, tmp_path: Path, estimator: str
) -> None:
    blend = tmp_path / "project" / "scene.blend"
    blend.parent.mkdir()
    result, output = blender(
        extension,
        tmp_path / "user",
        CAMERA_AND_WORLD
        + (SUN if estimator == "single" else "")
        + f"""
s = scene.occlux
s.volume_path = {str(phantom_npy(tmp_path))!r}
s.preset = "ct-soft-tissue"
s.output_dir = {str(tmp_path / "out") + "/"!r}
s.check_subject = "REFERENCE"
s.check_estimator, s.check_size, s.check_spp, s.check_seeds = {estimator!r}, 48, 128, 32
bpy.ops.wm.save_as_mainfile(filepath={str(blend)!r})
objects = sorted(o.name for o in bpy.data.objects)
result["op"] = list(bpy.ops.occlux.check_cycles())
result["panel"] = [s.check_rmse, s.check_rmse_over_noise, s.check_z_scale, s.check_agrees]
result["report"] = s.check_report
image = bpy.data.images["phantom-{estimator}-zmap.png"]
result["image_size"] = list(image.size)
result["unchanged"] = objects == sorted(o.name for o in bpy.data.objects)
result["scenes"] = [x.name for x in bpy.data.scenes]
""",
    )
    assert result["op"] == ["FINISHED"], output
    report_path = Path(result["report"])
    assert report_path == blend.parent / f"phantom-{estimator}-report.json"
    report = json.loads(report_path.read_text())
    assert (blend.parent / f"phantom-{estimator}-zmap.png").is_file()
    assert result["image_size"] == [48, 36], "the error map at the check's size, render aspect"
    figures = [report[k] for k in ("rmse", "rmse_over_noise", "z_scale", "mean_z")]
    assert all(np.isfinite(figures)) and report["pixels"] > 500, report
    # The agreement criteria of tests/python/test_cycles.py.
    assert ob.Z_SCALE_RANGE[0] <= report["z_scale"] <= ob.Z_SCALE_RANGE[1], report
    assert abs(report["mean_z"]) <= ob.MAX_ABS_MEAN_Z, report
    assert report["fraction_over_3"] <= ob.MAX_FRACTION_OVER_3, report
    assert 0.0 < report["rmse"] and report["rmse_over_noise"] < 1.5, report
    rmse, over_noise, z_scale, agrees = result["panel"]
    assert rmse == pytest.approx(report["rmse"], rel=1e-5) and agrees is True
    assert over_noise == pytest.approx(report["rmse_over_noise"], rel=1e-5)
    assert z_scale == pytest.approx(report["z_scale"], rel=1e-5)
    assert result["unchanged"] and result["scenes"] == ["Scene"], "the harness cleaned up"


def test_the_ambient_ao_material_renders_in_cycles_what_occlux_renders(
    extension: Path, tmp_path: Path
) -> None:
    """Compute AO with the `sweep-physical` grid and AMBIENT shading, rendered by Cycles under
    the world alone, against Occlux's AO-shaded render of the same scene (`method = "ao"`, no
    direct light): they differ by Cycles' noise only (relative RMSE within 1.3 x Cycles' own
    relative noise over the volume's pixels, bias within 2 %; measured 0.99 x and -0.1 % on
    this phantom at 64 spp). Without the camera-only world the volume is lit twice; without
    the camera-ray gate on the emission Cycles collects it again after its one scattering
    (+65 %)."""
    result, output = blender(
        extension,
        tmp_path / "user",
        CAMERA_AND_WORLD
        + f"""
import numpy as np
import occlux
import occlux.blender as ob
scenes = sys.modules["bl_ext.user_default.occlux.scenes"]
scene.render.resolution_x, scene.render.resolution_y = 64, 48
s = scene.occlux
s.volume_path = {str(phantom_npy(tmp_path))!r}
s.preset, s.device, s.output_dir = "ct-soft-tissue", "cpu", {str(tmp_path / "out") + "/"!r}
s.ao_method, s.ao_shading = "sweep-physical", "AMBIENT"
result["op"] = list(bpy.ops.occlux.compute_ao())
render = {{"method": "ao", "ao_method": "sweep-physical", "direct": False}}
described = scenes.scene_tree(bpy.context, scenes.selected_source(bpy.context), 64, 48,
                              ("ambient",), render=render)
beauty = np.asarray(occlux.render(scenes.build(described.tree), device="cpu").beauty)
ob.cycles_settings(scene, 0)  # unbiased, unfiltered, linear EXR
cycles = ob.render_scene(scene, 64, 8)
inside = beauty[..., 3] > 0.05
ours, theirs = beauty[..., :3][inside], cycles.mean[inside]
result["pixels"] = int(inside.sum())
result["rel_rmse"] = float(np.sqrt(np.mean((ours - theirs) ** 2)) / theirs.mean())
result["bias"] = float(ours.mean() / theirs.mean() - 1.0)
result["noise"] = float(np.sqrt(np.mean(cycles.stderr[inside] ** 2)) / theirs.mean())
world = scene.world.node_tree
result["world"] = sorted(n.name for n in world.nodes)
result["ambient"] = list(scenes.world_radiance(scene))  # still the world's colour
""",
    )
    assert result["op"] == ["FINISHED"], output
    assert result["pixels"] > 500, result
    assert result["rel_rmse"] <= 1.3 * result["noise"], result
    assert abs(result["bias"]) <= 0.02, result
    assert "Occlux world for camera rays only" in result["world"], result["world"]
    assert result["ambient"] == pytest.approx([1.0, 0.9, 0.8]), result


def figure_check(tmp_path: Path, blend: Path, method: str) -> str:
    """The script's start for a figure check of `method` on the phantom (the camera and world,
    a sun), at 48 x 36 pixels and 64 samples over 8 renders, from `blend` saved in its folder."""
    blend.parent.mkdir()
    return (
        CAMERA_AND_WORLD
        + SUN
        + f"""
s = scene.occlux
s.volume_path = {str(phantom_npy(tmp_path))!r}
s.preset, s.device = "ct-soft-tissue", "cpu"
s.output_dir = {str(tmp_path / "out") + "/"!r}
s.ao_method = "sweep-physical"
s.check_subject, s.check_method = "FIGURE", {method!r}
s.check_size, s.check_spp, s.check_seeds = 48, 64, 8
bpy.ops.wm.save_as_mainfile(filepath={str(blend)!r})
"""
    )


@pytest.mark.parametrize("method", ["ao", "dos", "ipsvi"])
def test_check_against_cycles_checks_the_figure(
    extension: Path, tmp_path: Path, method: str
) -> None:
    """Check the figure: the chosen method with the panel's settings against Cycles' truth of its
    lighting, on the phantom. The report's relative RMSE and bias are the ones numpy computes from
    the EXR the check wrote (Occlux's image and Cycles' mean, docs/architecture.md#error-measure's
    measure); the panel shows them; the error map is at least 256 pixels wide with a colour key
    below the image; a lamp DOS and AO do not render is named, not refused."""
    blend = tmp_path / "project" / "scene.blend"
    result, output = blender(
        extension,
        tmp_path / "user",
        figure_check(tmp_path, blend, method)
        + """
result["op"] = list(bpy.ops.occlux.check_cycles())
result["status"] = s.status
result["panel"] = [s.check_rel_rmse, s.check_bias, s.check_occlux_seconds,
                   s.check_cycles_seconds]
result["report"] = s.check_report
result["scenes"] = [x.name for x in bpy.data.scenes]
""",
    )
    assert result["op"] == ["FINISHED"], output
    stem = blend.parent / f"phantom-{method}-figure"
    report = json.loads(Path(result["report"]).read_text())
    assert Path(result["report"]) == Path(f"{stem}-report.json")
    assert report["method"]["method"] == method and report["size"] == [48, 36], report
    assert report["truth"]["estimator"] == ("single" if method == "ipsvi" else "ambient")
    layers = oiio_read(Path(f"{stem}.exr"))
    ours = np.stack([layers[f"occlux.{c}"] for c in "RGB"], axis=-1).astype(np.float64)
    truth = np.stack([layers[f"cycles.{c}"] for c in "RGB"], axis=-1).astype(np.float64)
    background = np.mean([1.0, 0.9, 0.8])  # the world, CAMERA_AND_WORLD's
    inside = np.abs(truth.mean(axis=-1) - background) > 0.005 * background
    assert inside.sum() == report["pixels"] > 300, report
    mean = truth[inside].mean()
    rel_rmse = np.sqrt(np.mean((ours[inside] - truth[inside]) ** 2)) / mean
    assert report["rel_rmse"] == pytest.approx(rel_rmse, rel=1e-4), report
    assert report["bias"] == pytest.approx(ours[inside].mean() / mean - 1.0, abs=1e-5), report
    assert report["occlux_seconds"] > 0 and report["cycles_seconds"] > 0, report
    rel, bias, occlux_seconds, cycles_seconds = result["panel"]
    assert rel == pytest.approx(report["rel_rmse"], rel=1e-5) and bias == pytest.approx(
        report["bias"], abs=1e-6
    )
    assert occlux_seconds == pytest.approx(report["occlux_seconds"], rel=1e-5)
    assert cycles_seconds == pytest.approx(report["cycles_seconds"], rel=1e-5)
    errors = oiio_read(Path(f"{stem}-errormap.png"))
    assert errors["R"].shape[1] >= 256 and errors["R"].shape[0] > errors["R"].shape[1] * 36 / 48
    if method == "ipsvi":
        assert "left out" not in result["status"], result["status"]
    else:
        assert "left out light 'Sun' (sun)" in result["status"], result["status"]
    assert result["scenes"] == ["Scene"], "the harness cleaned up"


def test_the_figure_check_renders_the_users_own_scene(extension: Path, tmp_path: Path) -> None:
    """With the dataset loaded as a Volume object, Check Against Cycles renders the user's scene
    as it stands: the object's material (its AO off), the camera, the world. On the phantom, AO
    with the physical sweep, AMBIENT-shaded, the figures equal those of the harness's mapping
    (verified against Occlux's reference, test_cycles.py) rendered at the same seeds once the
    object is gone: bias within 1 %, relative RMSE within 5 % (measured -8.6 % and 0.172 both,
    Cycles' own noise 0.14 at 64 spp). Halving the albedo in the user's material halves the
    light Cycles' truth scatters (single scattering is linear in the albedo; the extinction
    stays, and with it the world seen through the volume): the check rendered that material,
    not a mapping of its own (measured within 0.7 % of the closed form). The user's data is
    unchanged after each check (the material's AO, the camera-only world, the scenes); a
    cancel between Cycles' renders adds nothing and writes no report."""
    blend = tmp_path / "project" / "scene.blend"
    result, output = blender(
        extension,
        tmp_path / "user",
        figure_check(tmp_path, blend, "ao")
        + """
import glob, shutil, tempfile
from pathlib import Path
material = sys.modules["bl_ext.user_default.occlux.material"]
s.ao_shading = "AMBIENT"
checks = lambda: set(glob.glob(tempfile.gettempdir() + "/occlux-check-*"))
checks_before = checks()
result["load"] = list(bpy.ops.occlux.compute_ao())
obj = bpy.data.objects["phantom"]
shading = obj.active_material
tree = shading.node_tree

def user_state():
    world = scene.world.node_tree.nodes[material.CAMERA_ONLY]
    return [tree.nodes[material.AO_FACTOR].outputs[0].default_value,
            list(tree.nodes[material.AMBIENT].outputs[0].default_value),
            bool(world.inputs["Fac"].links), sorted(x.name for x in bpy.data.scenes),
            sorted(x.name for x in bpy.data.objects), sorted(x.name for x in bpy.data.materials)]

before = user_state()
result["op"] = list(bpy.ops.occlux.check_cycles())
result["status"] = s.status
first = json.loads(open(s.check_report).read())
result["first"] = {k: first[k] for k in ("rel_rmse", "bias", "cycles_scene", "left_out")}
result["unchanged"] = user_state() == before
stem = s.check_report[: -len("-report.json")]
shutil.copy(stem + ".exr", stem + "-full-albedo.exr")
result["exr"] = stem

# The user halves the albedo: a Multiply by 0.5 into the Principled Volume's Color.
principled = next(n for n in tree.nodes if n.bl_idname == "ShaderNodeVolumePrincipled")
albedo = principled.inputs["Color"].links[0].from_socket
half = tree.nodes.new("ShaderNodeMix")
half.data_type, half.blend_type = "RGBA", "MULTIPLY"
half.inputs["Factor"].default_value = 1.0
half.inputs[7].default_value = (0.5, 0.5, 0.5, 1.0)
tree.links.new(albedo, half.inputs[6])
tree.links.new(half.outputs[2], principled.inputs["Color"])
before = user_state()
result["op_half"] = list(bpy.ops.occlux.check_cycles())
second = json.loads(open(s.check_report).read())
result["second"] = {k: second[k] for k in ("rel_rmse", "bias")}
result["unchanged_half"] = user_state() == before
shutil.copy(stem + ".exr", stem + "-half-albedo.exr")

# Cancelled after the second of Cycles' renders: nothing added, no new report.
report = Path(s.check_report)
report.unlink()
result["cancelled"] = attempt(bpy.ops.occlux.check_cycles, cancel_after_steps=2)
result["cancel_status"] = s.status
result["report_after_cancel"] = report.exists()
result["unchanged_cancel"] = user_state() == before
result["temporary"] = sorted(checks() - checks_before)

# Without the object, the harness maps the panel's classification of the file onto Cycles.
for o in list(bpy.data.objects):
    if o.type == "VOLUME":
        bpy.data.objects.remove(o)
result["op_harness"] = list(bpy.ops.occlux.check_cycles())
harness = json.loads(open(s.check_report).read())
result["harness"] = {k: harness[k] for k in ("rel_rmse", "bias", "cycles_scene")}
""",
    )
    assert result["load"] == ["FINISHED"] and result["op"] == ["FINISHED"], output
    first = result["first"]
    assert first["cycles_scene"]["volume_object"] == "phantom", first
    assert first["cycles_scene"]["lamps"] == [] and first["cycles_scene"]["world"], first
    assert "left out light 'Sun' (sun)" in result["status"], result["status"]
    assert result["op_harness"] == ["FINISHED"], output
    harness = result["harness"]
    assert "harness" in harness["cycles_scene"], harness
    assert first["bias"] == pytest.approx(harness["bias"], abs=0.01), (first, harness)
    assert first["rel_rmse"] == pytest.approx(harness["rel_rmse"], rel=0.05), (first, harness)
    assert abs(first["bias"]) < 0.12, first  # the sweep's error on this phantom
    assert result["unchanged"], "the check leaves the user's material, world and scenes"
    assert result["op_half"] == ["FINISHED"], output
    # Cycles' pixel is the world seen through the volume, B (1 - alpha), plus the scattered
    # light, which halves with the albedo (alpha from Occlux's render of the same medium).
    full = oiio_read(Path(result["exr"] + "-full-albedo.exr"))
    half = oiio_read(Path(result["exr"] + "-half-albedo.exr"))
    seen = np.stack([full[f"cycles.{c}"] for c in "RGB"], axis=-1).astype(np.float64)
    halved = np.stack([half[f"cycles.{c}"] for c in "RGB"], axis=-1).astype(np.float64)
    through = np.multiply.outer(1.0 - full["occlux.A"], [1.0, 0.9, 0.8])  # CAMERA_AND_WORLD's
    inside = full["occlux.A"] > 0.05
    want = (seen + through) / 2.0
    assert halved[inside].mean() == pytest.approx(want[inside].mean(), rel=0.03)
    assert result["second"]["bias"] > first["bias"] + 0.3, (first, result["second"])
    assert result["unchanged_half"]
    assert result["cancelled"] == ["CANCELLED"], output
    assert "Check Against Cycles: cancelled, nothing was added" in result["cancel_status"]
    assert not result["report_after_cancel"] and result["unchanged_cancel"], output
    assert result["temporary"] == [], "the check's temporary folders are removed"


def method_render(tmp_path: Path, out: Path, preset: str) -> str:
    """The script's start for a method render: the camera and world, the phantom with `preset`,
    output into `out`, the CPU, 48 x 36 pixels."""
    return (
        CAMERA_AND_WORLD
        + f"""
import occlux.blender as ob
s = scene.occlux
s.volume_path = {str(phantom_npy(tmp_path))!r}
s.preset = {preset!r}
s.output_dir = {str(out) + "/"!r}
s.device = "cpu"
scene.render.resolution_percentage = 12  # 48 x 36
"""
    )


def check_factor_layer(channels: dict, layer: str) -> None:
    """A compositing layer as the core writes it: V, the factor premultiplied by coverage, and
    A, the coverage, equal to the beauty's alpha (float16 in the EXR); V in [0, A], and
    V = A = 0 where nothing is seen."""
    coverage, value, alpha = channels[f"{layer}.A"], channels[f"{layer}.V"], channels["beauty.A"]
    assert (alpha > 0.5).sum() > 300
    np.testing.assert_allclose(coverage, alpha, atol=2e-3)
    assert value.min() >= 0.0 and (value <= coverage + 1e-3).all()
    empty = alpha == 0.0
    assert empty.any() and (value[empty] == 0.0).all() and (coverage[empty] == 0.0).all()


def test_render_dos_writes_the_exr_layers_for_the_compositor(
    extension: Path, tmp_path: Path
) -> None:
    out = tmp_path / "out"
    result, output = blender(
        extension,
        tmp_path / "user",
        method_render(tmp_path, out, "ct-soft-tissue")
        + f"""
s.dos_theta_deg, s.dos_grid, s.dos_distance = 30.0, 3, "approximate"
s.dos_sampling = "area"
s.dos_slice_distance = 0.05
result["op"] = list(bpy.ops.occlux.render_dos())
result["exr"] = s.last_exr
_, header = ob.read_channels(s.last_exr)
ob.check_camera(scene, json.loads(header["occlux/camera"]))  # Blender's camera, as rendered
result["method"] = json.loads(header["occlux/method"])
result["lighting"] = json.loads(header["occlux/lighting"])
result["composite"] = list(bpy.ops.occlux.composite(filepath=s.last_exr, layer="occlusion"))
tree = scene.compositing_node_group
image = next(n for n in tree.nodes if n.bl_idname == "CompositorNodeImage")
result["occlusion_to"] = [l.to_node.bl_idname for l in image.outputs["occlusion"].links]
# DOS is lit by the world alone: a sun is left out, and the report says so.
sun = bpy.data.objects.new("Sun", bpy.data.lights.new("Sun", "SUN"))
scene.collection.objects.link(sun)
s.output_dir = {str(tmp_path / "out2") + "/"!r}
result["with_sun"] = [attempt(bpy.ops.occlux.render_dos), s.status]
# The core's notices name the panel's Device setting, not the CLI's flag.
s.device, s.output_dir = "auto", {str(tmp_path / "out3") + "/"!r}
result["auto"] = [attempt(bpy.ops.occlux.render_dos), s.status]
""",
    )
    assert result["op"] == ["FINISHED"], output
    exr = out / "phantom-dos.exr"
    assert result["exr"] == str(exr) and sorted(p.name for p in out.iterdir()) == [exr.name]
    method = result["method"]  # the panel's DOS parameters reached the render
    assert method["method"] == "dos", method
    assert method["theta_deg"] == pytest.approx(30.0) and method["grid"] == 3, method
    assert method["slice_distance"] == pytest.approx(0.05) and method["distance"] == "approximate"
    assert method["sampling"] == "area", method
    lights = result["lighting"]["lights"]  # the world, as the one ambient light
    assert [light["type"] for light in lights] == ["ambient"], lights
    assert lights[0]["radiance"] == pytest.approx([1.0, 0.9, 0.8]), lights
    channels = oiio_read(exr)
    assert sorted(channels) == sorted(
        [f"beauty.{c}" for c in "RGBA"] + ["depth.Z", "occlusion.A", "occlusion.V"]
    )  # fmt: skip: the shaded image is `beauty` alone, no copy under the method's name
    assert channels["occlusion.V"].shape == (36, 48)
    check_factor_layer(channels, "occlusion")
    alpha, lit = channels["beauty.A"], channels["occlusion.V"]
    inside = alpha > 0.5
    ratio = lit[inside] / alpha[inside]
    assert ratio.mean() < 0.95, "the phantom occludes its own ambient light"
    assert result["composite"] == ["FINISHED"]
    assert result["occlusion_to"] == ["ShaderNodeSeparateXYZ"]  # X = A, Y = V
    with_sun, status = result["with_sun"]
    assert with_sun == ["FINISHED"], status
    assert "left out light 'Sun' (sun): this method renders the world's ambient light" in status
    assert (tmp_path / "out2" / "phantom-dos.exr").is_file()
    auto, status = result["auto"]
    assert auto == ["FINISHED"] and "--device" not in status, status
    if "software rasterizer" in status:  # lavapipe: the CPU is used, and the panel named
        assert "Device: GPU in the Occlux panel" in status, status
    # Outputs are ordinary files others may read (the core's atomic writer).
    assert (exr.stat().st_mode & 0o644) == 0o644, oct(exr.stat().st_mode)


def test_render_ipsvi_lights_by_the_lamps_and_writes_its_layers(
    extension: Path, tmp_path: Path
) -> None:
    out = tmp_path / "out"
    result, output = blender(
        extension,
        tmp_path / "user",
        method_render(tmp_path, out, "ct-bone")
        + """
# No lamp yet: IPSVI renders suns and point lamps, not the world.
result["no_lamp"] = attempt(bpy.ops.occlux.render_ipsvi)
sun = bpy.data.objects.new("Sun", bpy.data.lights.new("Sun", "SUN"))
sun.data.energy = 3.0
sun.rotation_euler = (0.6, 0.2, -0.4)
scene.collection.objects.link(sun)
lamp = bpy.data.objects.new("Lamp", bpy.data.lights.new("Lamp", "POINT"))
lamp.data.energy, lamp.data.color = 400.0, (1.0, 0.5, 0.25)
lamp.location = (1.5, -2.5, 2.0)
scene.collection.objects.link(lamp)
s.ipsvi_line_width, s.ipsvi_cache_size, s.ipsvi_g = 2, 96, 0.3
s.ipsvi_scattering = "multiple"
bpy.context.view_layer.update()
result["sun_z"] = list(sun.matrix_world.col[2].xyz.normalized())
result["op"] = list(bpy.ops.occlux.render_ipsvi())
result["exr"] = s.last_exr
_, header = ob.read_channels(s.last_exr)
result["method"] = json.loads(header["occlux/method"])
result["lighting"] = json.loads(header["occlux/lighting"])
result["composite"] = list(bpy.ops.occlux.composite(filepath=s.last_exr, layer="shadow"))
""",
    )
    assert "no light" in result["no_lamp"] and "sun light" in result["no_lamp"], result["no_lamp"]
    assert result["op"] == ["FINISHED"], output
    exr = out / "phantom-ipsvi.exr"
    assert result["exr"] == str(exr) and sorted(p.name for p in out.iterdir()) == [exr.name]
    method = result["method"]  # the panel's parameters reached the render
    assert method["method"] == "ipsvi" and method["line_width"] == 2, method
    assert method["cache_size"] == 96 and method["g"] == pytest.approx(0.3), method
    assert method["scattering"] == "multiple", method
    lights = result["lighting"]["lights"]  # the lamps, not the world
    assert [light["type"] for light in lights] == ["directional", "point"], lights
    assert lights[0]["to_light"] == pytest.approx(result["sun_z"], abs=1e-6)
    assert lights[0]["irradiance"] == pytest.approx([3.0] * 3)
    assert lights[1]["position"] == pytest.approx([1.5, -2.5, 2.0])
    # Cycles' point lamp of power P has radiant intensity P / (4 pi).
    per_steradian = 400.0 / (4 * np.pi)
    assert lights[1]["intensity"] == pytest.approx([per_steradian * c for c in (1, 0.5, 0.25)])
    assert result["lighting"]["background"] == pytest.approx([1.0, 0.9, 0.8])
    channels = oiio_read(exr)
    assert sorted(channels) == sorted(
        [f"beauty.{c}" for c in "RGBA"] + ["depth.Z", "shadow.A", "shadow.V"]
    )  # fmt: skip: the shaded image is `beauty` alone, no copy under the method's name
    check_factor_layer(channels, "shadow")
    alpha, lit = channels["beauty.A"], channels["shadow.V"]
    inside = alpha > 0.5
    assert (lit[inside] / alpha[inside] < 0.5).any(), "the phantom shadows part of itself"
    assert result["composite"] == ["FINISHED"]


def test_the_guides_script_makes_its_figure_on_the_factory_scene(tmp_path: Path) -> None:
    """docs/blender.md's script, run verbatim by docs/make_blender_figure.py on Blender's factory
    scene (its Cube, Light and Camera), ends with one volume object and a figure: the tooth
    covers part of the frame, lit through Bake Light by the sky and the sun, on a transparent
    background."""
    png = tmp_path / "figure.png"
    script = REPO / "docs" / "make_blender_figure.py"
    run = subprocess.run(
        [sys.executable, str(script), "--out", str(png)], capture_output=True, text=True,
        timeout=600,
    )  # fmt: skip
    output = run.stdout + run.stderr
    assert run.returncode == 0, output
    assert "baked the world and 1 lamp(s) into 'tooth'" in output, output
    assert "objects: Camera, Light, tooth" in run.stdout, run.stdout
    pixels = oiio_read(png)
    assert sorted(pixels) == ["A", "B", "G", "R"] and pixels["R"].shape == (320, 320)
    tooth = pixels["A"] > 0.5
    assert 0.05 < tooth.mean() < 0.6, "the tooth is framed, on a transparent background"
    grey = (pixels["R"] + pixels["G"] + pixels["B"])[tooth] / 3.0
    assert 0.3 < np.median(grey) < 0.95 and grey.std() > 0.02, "lit, with shading"


def test_the_workflow_measured_on_the_tooth_against_cycles(tmp_path: Path) -> None:
    """docs/measure_blender_check.py on the guide's scene at 64 x 64: the check's figures and
    Cycles' renders of the AO wiring against the truth of the sky's light. The AMBIENT wiring
    and the AO-shaded figure are within 10 % of the truth's mean (measured -5 % at 256 px),
    IPSVI within 5 % of the sun's (+0.3 %), while the darkened albedo, the world's light
    occluded twice, is more than 30 % too dark (-50 %); the DOS composite keeps a share of the
    light, neither all nor half of it gone."""
    out = tmp_path / "measured.json"
    script = REPO / "docs" / "measure_blender_check.py"
    run = subprocess.run(
        [sys.executable, str(script), "--size", "64", "--json", str(out)], capture_output=True,
        text=True, timeout=600,
    )  # fmt: skip
    assert run.returncode == 0, run.stdout + run.stderr
    measured = json.loads(out.read_text())
    assert abs(measured["check: ao vs Cycles (ambient)"]["bias"]) < 0.1, measured
    assert abs(measured["check: ipsvi vs Cycles (single)"]["bias"]) < 0.05, measured
    assert abs(measured["Cycles render, AO wired as AMBIENT"]["bias"]) < 0.1, measured
    assert measured["Cycles render, AO wired as ALBEDO"]["bias"] < -0.3, measured
    assert 0.5 < measured["composite (DOS occlusion, strength 1)"]["kept"] < 0.95, measured
    assert measured["check: dos vs Cycles (ambient)"]["pixels"] > 500, measured


# A stand-in window manager (a headless Blender has no window to run modal operators in) that
# records its calls, the events Blender's loop sends, and `stand_in(operator)`: the operator's
# methods on a plain OccluxJob, whose invoke and modal the tests drive as that loop would.
MODAL_STAND_IN = """
import time
from types import SimpleNamespace
jobs = sys.modules["bl_ext.user_default.occlux.operators.jobs"]
calls = []

class WindowManager:
    windows = []
    def event_timer_add(self, step, window):
        calls.append("timer_add")
        return "timer"
    def event_timer_remove(self, timer):
        calls.append("timer_remove")
    def modal_handler_add(self, op):
        calls.append("modal_handler_add")
    def progress_begin(self, lo, hi):
        calls.append("progress_begin")
    def progress_update(self, value):
        calls.append(round(value, 3))
    def progress_end(self):
        calls.append("progress_end")

def stand_in(operator):
    methods = {k: v for k, v in vars(operator).items() if callable(v) and k[:2] != "__"}
    return type(operator.__name__, (jobs.OccluxJob,), {
        **methods, "bl_label": operator.bl_label, "cancel_after": 0, "cancel_after_steps": 0,
        "report": lambda self, kind, message: calls.append((sorted(kind)[0], message))})

context = SimpleNamespace(
    window="window", window_manager=WindowManager(), scene=bpy.context.scene,
    view_layer=bpy.context.view_layer)
timer = SimpleNamespace(type="TIMER", value="NOTHING")
esc = SimpleNamespace(type="ESC", value="PRESS")
"""


def test_the_modal_path_polls_the_thread_and_esc_cancels(extension: Path, tmp_path: Path) -> None:
    """invoke and modal as Blender's event loop drives them, with a stand-in window manager
    (a headless Blender has no window to run modal operators in): timer events update the
    progress until the thread ends, ESC cancels it."""
    out = tmp_path / "out"
    result, output = blender(
        extension,
        tmp_path / "user",
        MODAL_STAND_IN
        + f"""
from pathlib import Path
volume_ops = sys.modules["bl_ext.user_default.occlux.operators.volume"]
ComputeAO = stand_in(volume_ops.OCCLUX_OT_compute_ao)
s = bpy.context.scene.occlux
s.volume_path = {str(SHARED / "tooth.nrrd")!r}
s.output_dir = {str(out) + "/"!r}
s.ao_method, s.ao_radius, s.device = "exact", 8, "cpu"

def drive(op, esc_at=None):
    state = op.invoke(context, None)
    states, statuses = [state], []
    while state == {{"RUNNING_MODAL"}}:
        time.sleep(0.02)
        if esc_at is not None and op._run.progress.fraction > esc_at:
            state = op.modal(context, esc)
            esc_at = None
        else:
            state = op.modal(context, timer)
        states.append(state)
        statuses.append(s.status)
    return sorted(state), len(states), statuses

objects = len(bpy.data.objects), len(bpy.data.volumes), len(bpy.data.materials)
result["cancel"] = drive(ComputeAO(), esc_at=0.05)
result["cancel_calls"] = list(calls)
result["unchanged"] = objects == (
    len(bpy.data.objects), len(bpy.data.volumes), len(bpy.data.materials))
out = Path({str(out)!r})
result["files_after_cancel"] = sorted(p.name for p in out.glob("*"))
calls.clear()
s.ao_method, s.ao_radius = "cdf", 4
result["done"] = drive(ComputeAO())
result["done_calls"] = list(calls)
result["object"] = "tooth" in bpy.data.objects
""",
    )
    state, steps, statuses = result["cancel"]
    assert state == ["CANCELLED"] and steps > 2, result["cancel"]
    assert "Compute AO: cancelling" in statuses, statuses
    calls = result["cancel_calls"]
    assert calls[:3] == ["timer_add", "progress_begin", "modal_handler_add"], calls
    assert ["WARNING", "Compute AO: cancelled, nothing was added"] in calls, calls
    assert calls.index("timer_remove") < calls.index("progress_end"), calls
    assert result["unchanged"] and result["files_after_cancel"] == [], output
    state, steps, statuses = result["done"]
    assert state == ["FINISHED"] and result["object"], result["done"]
    written = [p.name for p in out.iterdir()]
    assert len(written) == 1 and AO_VDB.fullmatch(written[0]), written
    calls = result["done_calls"]
    updates = [c for c in calls if isinstance(c, float)]
    assert updates and all(0.0 <= u <= 1.0 for u in updates), calls
    assert calls[-2:][0] == "progress_end" and calls[-1][0] == "INFO", calls
    assert statuses[-1].startswith("AO (cdf, radius 4) of tooth.nrrd"), statuses


def test_the_checks_cycles_renders_show_progress_and_esc_cancels_between_them(
    extension: Path, tmp_path: Path
) -> None:
    """The check's modal path with a stand-in window manager (as above): after Occlux's half on
    its thread, each timer event runs one of Cycles' renders on the main thread and the status
    counts them; ESC between two renders cancels at once, removes the harness's scene and the
    temporary files and writes no report; run to the end, the check reports."""
    result, output = blender(
        extension,
        tmp_path / "user",
        CAMERA_AND_WORLD
        + MODAL_STAND_IN
        + f"""
import glob, tempfile
check_ops = sys.modules["bl_ext.user_default.occlux.operators.check"]
Check = stand_in(check_ops.OCCLUX_OT_check_cycles)
s = scene.occlux
s.volume_path = {str(phantom_npy(tmp_path))!r}
s.preset, s.device = "ct-soft-tissue", "cpu"
s.output_dir = {str(tmp_path / "out") + "/"!r}
s.check_subject, s.check_method = "FIGURE", "dos"
s.check_size, s.check_spp, s.check_seeds = 32, 16, 4
result["load"] = list(bpy.ops.occlux.import_volume())
checks = lambda: set(glob.glob(tempfile.gettempdir() + "/occlux-check-*"))
checks_before = checks()

def drive(esc_after=None):
    op = Check()
    state, statuses = op.invoke(context, None), []
    while state == {{"RUNNING_MODAL"}}:
        time.sleep(0.02)
        renders = sum(1 for x in statuses if "Cycles render" in x)
        event = esc if esc_after is not None and renders > esc_after else timer
        state = op.modal(context, event)
        statuses.append(s.status)
    return sorted(state), statuses

result["cancel"] = drive(esc_after=1)
result["cancel_calls"] = list(calls)
result["after_cancel"] = [sorted(x.name for x in bpy.data.scenes), sorted(checks() - checks_before),
                          s.check_report]
calls.clear()
result["done"] = drive()
result["done_calls"] = list(calls)
result["report"] = s.check_report
""",
    )
    assert result["load"] == ["FINISHED"], output
    state, statuses = result["cancel"]
    assert state == ["CANCELLED"], result["cancel"]
    assert "Check Against Cycles: Cycles render 0 of 4 (Esc cancels)" in statuses, statuses
    assert "Check Against Cycles: Cycles render 1 of 4 (Esc cancels)" in statuses, statuses
    assert not any("Cycles render 3 of 4" in x for x in statuses), "ESC stopped the renders"
    calls = result["cancel_calls"]
    assert ["WARNING", "Check Against Cycles: cancelled, nothing was added"] in calls, calls
    assert calls.index("timer_remove") < calls.index("progress_end"), calls
    assert result["after_cancel"] == [["Scene"], [], ""], result["after_cancel"]
    state, statuses = result["done"]
    assert state == ["FINISHED"], result["done"]
    renders = [x for x in statuses if "Cycles render" in x]
    assert renders[-1] == "Check Against Cycles: Cycles render 4 of 4 (Esc cancels)", statuses
    updates = [c for c in result["done_calls"] if isinstance(c, float)]
    assert [0.0, 0.25, 0.5, 0.75, 1.0] == updates[-5:], updates
    assert result["done_calls"][-1][0] == "INFO" and result["report"].endswith(
        "phantom-dos-figure-report.json"
    ), result["done_calls"]


def test_property_limits_defaults_and_choices_come_from_the_registry(
    extension: Path, tmp_path: Path
) -> None:
    """The panel's DOS, AO and IPSVI settings take their limits, defaults and choices from the
    core's method registry (`occlux.methods()`), and what they clamp to is what the core
    accepts."""
    result, _ = blender(
        extension,
        tmp_path / "user",
        """
        s = bpy.context.scene.occlux
        props = s.bl_rna.properties
        def number(name):
            p = props[name]
            return {"min": p.hard_min, "max": p.hard_max, "default": p.default,
                    "description": p.description}
        def choice(name):
            p = props[name]
            return {"items": [[i.identifier, i.description] for i in p.enum_items],
                    "default": p.default, "description": p.description}
        result["numbers"] = {n: number(n) for n in ("dos_theta_deg", "dos_grid", "ao_radius")}
        result["choices"] = {
            n: choice(n)
            for n in ("dos_distance", "dos_sampling", "ao_method", "ipsvi_scattering", "preset")
        }
        s.dos_theta_deg, s.dos_grid, s.ao_radius = 95.0, 99, 100000
        result["clamped"] = [s.dos_theta_deg, s.dos_grid, s.ao_radius]
        # The clamped values are ones the core takes.
        occlux.Scene.from_dict({"volume": {"phantom": "sphere"},
            "camera": {"position": [0, -4, 0]},
            "render": {"method": "dos", "theta_deg": s.dos_theta_deg, "grid": s.dos_grid}})
        """,
    )
    registry = {m["name"]: {p["key"]: p for p in m["params"]} for m in occlux.methods()}
    dos, ao, ipsvi = registry["dos"], registry["ao"], registry["ipsvi"]
    numbers, choices = result["numbers"], result["choices"]

    theta, grid, radius = numbers["dos_theta_deg"], numbers["dos_grid"], numbers["ao_radius"]
    assert dos["theta_deg"]["range"]["max_inclusive"] is False  # [0, 90): max just below
    assert dos["theta_deg"]["range"]["max"] - 0.11 < theta["max"] < dos["theta_deg"]["range"]["max"]
    assert theta["min"] == dos["theta_deg"]["range"]["min"]
    assert theta["default"] == pytest.approx(dos["theta_deg"]["default"])
    assert dos["theta_deg"]["doc"] in theta["description"], theta
    assert [grid["min"], grid["max"], grid["default"]] == [
        dos["grid"]["range"]["min"], dos["grid"]["range"]["max"], dos["grid"]["default"]
    ]  # fmt: skip
    assert [radius["min"], radius["max"], radius["default"]] == [
        ao["ao_radius"]["range"]["min"], ao["ao_radius"]["range"]["max"],
        ao["ao_radius"]["default"],
    ]  # fmt: skip
    assert result["clamped"] == [pytest.approx(theta["max"]), grid["max"], radius["max"]]

    for prop, param in (
        ("dos_distance", dos["distance"]),
        ("dos_sampling", dos["sampling"]),
        ("ao_method", ao["ao_method"]),
        ("ipsvi_scattering", ipsvi["scattering"]),
    ):
        want = [[o["name"], o["doc"]] for o in param["options"]]
        assert choices[prop]["items"] == want, (prop, choices[prop])
        assert choices[prop]["default"] == param["default"]
        assert choices[prop]["description"] == param["doc"]
    assert [i for i, _ in choices["preset"]["items"]] == occlux.PRESETS


def test_a_raw_volume_over_the_memory_budget_is_refused_by_the_core(
    extension: Path, tmp_path: Path
) -> None:
    """The panel's raw layout and memory budget reach the core's raw loader, which refuses a
    volume whose float32 copy exceeds the budget, naming the file and the budget, before
    anything is written; under a larger budget the same file loads."""
    raw = tmp_path / "scan.raw"
    raw.write_bytes(np.arange(128 * 128 * 64, dtype=np.uint8).tobytes())  # 4 MB as float32
    out = tmp_path / "out"
    result, output = blender(
        extension,
        tmp_path / "user",
        CAMERA_AND_WORLD
        + MASK_SIDES
        + f"""
import glob, tempfile
s = scene.occlux
s.volume_path = {str(raw)!r}
s.raw_dims, s.raw_type, s.raw_spacing = (128, 128, 64), "uint8", (1.0, 1.0, 2.0)
s.output_dir = {str(out) + "/"!r}
s.memory_budget_mb, s.device, s.check_spp, s.check_seeds = 1, "cpu", 2, 2
counts = lambda: [len(bpy.data.objects), len(bpy.data.volumes), len(bpy.data.images)]
checks = lambda: set(glob.glob(tempfile.gettempdir() + "/occlux-check-*"))
before, checks_before = counts(), checks()
result["refused"] = {{op: attempt(getattr(bpy.ops.occlux, op))
    for op in ("import_volume", "compute_ao", "render_dos", "check_cycles")}}
result["unchanged"] = before == counts() and checks() == checks_before
import os
result["written"] = sorted(os.listdir({str(out)!r})) if os.path.isdir({str(out)!r}) else []
s.memory_budget_mb = 8
result["loaded"] = attempt(bpy.ops.occlux.import_volume)
obj = bpy.data.objects["scan"]
result["sides"] = mask_sides(obj)
""",
    )
    for op, message in result["refused"].items():
        assert "scan.raw" in message and "128x128x64" in message, (op, message)
        assert "available (volume.memory_budget_gib)" in message, (op, message)
        assert "Memory budget in the Occlux panel: 1 MB" in message, (op, message)
    assert result["unchanged"] and result["written"] == [], output
    assert result["loaded"] == ["FINISHED"], output
    # The raw layout reached the loader: 128 x 128 x 64 voxels of spacing (1, 1, 2), fitted.
    assert result["sides"] == pytest.approx([2.0, 2.0, 2.0], abs=0.05), result["sides"]


def test_the_scene_built_from_blender_describes_blenders_camera(
    extension: Path, tmp_path: Path
) -> None:
    """The scene the add-on builds from the Blender scene (`Scene.from_dict`) describes the
    camera Blender renders with (perspective with either sensor fit, and orthographic) and the
    world as its ambient light."""
    result, _ = blender(
        extension,
        tmp_path / "user",
        CAMERA_AND_WORLD
        + f"""
import occlux.blender as ob
scenes = sys.modules["bl_ext.user_default.occlux.scenes"]
s = scene.occlux
s.volume_path = {str(phantom_npy(tmp_path))!r}
cases = {{}}
for name, kind, fit, size in (("auto", "PERSP", "AUTO", (400, 300)),
                              ("vertical", "PERSP", "VERTICAL", (300, 400)),
                              ("ortho", "ORTHO", "AUTO", (300, 400))):
    camera.data.type, camera.data.sensor_fit = kind, fit
    camera.data.ortho_scale = 3.0
    scene.render.resolution_x, scene.render.resolution_y = size
    tree = scenes.scene_tree(bpy.context, scenes.VolumeInput.from_settings(s), *size).tree
    described = scenes.build(tree).describe()
    cases[name] = {{"occlux": described["camera"], "blender": ob.camera_frustum(scene),
                    "lights": described["lighting"]["lights"]}}
result["cases"] = cases
""",
    )
    for name, case in result["cases"].items():
        ours, blender_camera = case["occlux"], case["blender"]
        for key in ("position", "forward", "up", "half_extent"):
            np.testing.assert_allclose(
                ours[key], blender_camera[key], rtol=1e-4, atol=1e-4, err_msg=f"{name} {key}"
            )
        assert (ours["projection"]["type"] == "perspective") == blender_camera["perspective"]
        assert [light["type"] for light in case["lights"]] == ["ambient"], case["lights"]
        assert case["lights"][0]["radiance"] == pytest.approx([1.0, 0.9, 0.8])
    assert result["cases"]["ortho"]["occlux"]["projection"]["type"] == "orthographic"
