"""`occlux export` through the real readers: OpenVDB 12 (from the bpy wheel), usd-core, and
Blender 5 (volume grids, USD import, the compositor reading each EXR layer).

Each test exports a small NRRD volume with anisotropic voxels through the CLI, so the values,
the voxel-to-world transform and the camera are known here independently of Occlux.
"""

from __future__ import annotations

import math
import subprocess
from pathlib import Path

import numpy as np
import pytest
from occlux_testing import (
    occlux_binary,
    oiio_read,
    run_occlux,
    usd_validation_errors,
)

# The test volume: x fastest in the file; spacing and placement as the scene below sets them.
DIMS = (40, 24, 16)  # nx, ny, nz
SPACINGS = (0.5, 1.0, 2.0)
FIT = 2.0  # the largest extent (24 and 32 units) becomes 2 scene units
CENTRE = (0.25, -0.5, 1.0)
FOV_DEG = 35.0
SIZE = (48, 32)


def make_values() -> np.ndarray:
    """A smooth blob plus a ramp, zero (inactive) outside a sphere; shape (nz, ny, nx)."""
    nx, ny, nz = DIMS
    z, y, x = np.meshgrid(np.arange(nz), np.arange(ny), np.arange(nx), indexing="ij")
    px, py, pz = (x * SPACINGS[0] - 10, y * SPACINGS[1] - 12, z * SPACINGS[2] - 16)
    r2 = px**2 + py**2 + pz**2
    values = np.where(r2 < 100.0, 100.0 + 50.0 * np.exp(-r2 / 30.0) + 0.7 * x, 0.0)
    return values.astype(np.float32)


def write_scene(folder: Path, values: np.ndarray) -> Path:
    nx, ny, nz = DIMS
    header = (
        "NRRD0004\ntype: float\ndimension: 3\n"
        f"sizes: {nx} {ny} {nz}\nspacings: {' '.join(map(str, SPACINGS))}\n"
        "encoding: raw\nendian: little\n\n"
    )
    (folder / "blob.nrrd").write_bytes(header.encode() + values.astype("<f4").tobytes())
    scene = folder / "blob.toml"
    scene.write_text(
        f"""
background = 0.05
[volume]
path = "blob.nrrd"
fit = {FIT}
centre = {list(CENTRE)}
[classification]
units = "raw"
points = [
  {{ value = 100, sigma_t = 0, albedo = [0.8, 0.6, 0.4] }},
  {{ value = 200, sigma_t = 30, albedo = [0.8, 0.6, 0.4] }},
]
[camera]
position = [4.0, -3.0, 2.5]
target = {list(CENTRE)}
fov_deg = {FOV_DEG}
width = {SIZE[0]}
height = {SIZE[1]}
[[lights]]
type = "ambient"
radiance = 0.2
[[lights]]
type = "directional"
direction = [-0.3, -1.0, 1.2]
irradiance = 2.0
[[lights]]
type = "point"
position = [1.0, 2.0, 3.0]
intensity = 5.0
[render]
method = "gradient"
"""
    )
    return scene


def expected_placement() -> tuple[np.ndarray, np.ndarray]:
    """Voxel size and the world position of voxel (0, 0, 0), as the scene places the volume."""
    spacing = np.array(SPACINGS)
    extent = np.array(DIMS) * spacing
    scale = FIT / extent.max()
    voxel = spacing * scale
    origin = np.array(CENTRE) - 0.5 * extent * scale + 0.5 * voxel
    return voxel, origin


@pytest.fixture(scope="module")
def blob(tmp_path_factory) -> tuple[Path, np.ndarray]:
    folder = tmp_path_factory.mktemp("blob")
    values = make_values()
    return write_scene(folder, values), values


def export(scene: Path, out: Path, *flags: str) -> dict[str, Path]:
    run_occlux("export", str(scene), "-o", str(out), "--device", "cpu", "--quiet", *flags)
    return {p.suffix: p for p in out.iterdir()}


@pytest.mark.parametrize(
    "flags",
    [(), ("--compression", "none"), ("--half",), ("--half", "--compression", "none")],
)
def test_openvdb_reads_values_and_transform(blob, tmp_path, flags, openvdb):
    scene, values = blob
    files = export(scene, tmp_path, *flags)
    grids, _ = openvdb.readAll(str(files[".vdb"]))
    by_name = {g.name: g for g in grids}
    assert sorted(by_name) == ["density", "value"]
    voxel, origin = expected_placement()
    half = "--half" in flags
    want_values = values.astype(np.float16).astype(np.float32) if half else values
    # extinction: the transfer function's ramp, 30 * clip((v - 100) / 100, 0, 1) per unit
    want_density = 30.0 * np.clip((values - 100.0) / 100.0, 0.0, 1.0)
    for name, want, tol in [("value", want_values, 0.0), ("density", want_density, 2e-3)]:
        grid = by_name[name]
        assert grid.gridClass == "fog volume"
        assert grid.metadata["class"] == "fog volume"
        np.testing.assert_allclose(grid.transform.voxelSize(), voxel, rtol=1e-6)
        np.testing.assert_allclose(grid.transform.indexToWorld((0, 0, 0)), origin, atol=1e-6)
        dense = np.zeros(DIMS, dtype=np.float32)  # x, y, z
        grid.copyToArray(dense, ijk=(0, 0, 0))
        got = dense.transpose(2, 1, 0)
        if half and name == "density":
            tol = 1e-2
        np.testing.assert_allclose(got, want, rtol=tol, atol=tol * 30.0)
        # Padded by one voxel repeating the border (what Cycles' fade needs), the grid's own
        # index box in the metadata.
        padded = np.pad(want, 1, mode="edge")
        assert grid.activeVoxelCount() == np.count_nonzero(padded)
        nz = np.argwhere(padded) - 1  # (z, y, x)
        lo, hi = grid.evalActiveVoxelBoundingBox()
        assert tuple(lo) == tuple(nz.min(0)[::-1]) and tuple(hi) == tuple(nz.max(0)[::-1])
        assert tuple(grid.metadata["occlux_box_min"]) == (0, 0, 0)
        assert tuple(grid.metadata["occlux_box_max"]) == tuple(d - 1 for d in DIMS)
        ring = np.zeros([d + 2 for d in DIMS], dtype=np.float32)
        grid.copyToArray(ring, ijk=(-1, -1, -1))
        np.testing.assert_array_equal(ring, np.pad(dense, 1, mode="edge"))


def test_storage_options_trade_size(blob, tmp_path):
    scene, _ = blob
    sizes = {}
    for label, flags in [("none", ("--compression", "none")), ("zip", ()), ("half", ("--half",))]:
        sizes[label] = export(scene, tmp_path / label, *flags)[".vdb"].stat().st_size
    assert sizes["zip"] < sizes["none"]
    assert sizes["half"] < sizes["zip"]


def test_blender_loads_the_grids(blob, tmp_path):
    import bpy

    scene, values = blob
    vdb = export(scene, tmp_path)[".vdb"]
    bpy.ops.wm.read_factory_settings(use_empty=True)
    volume = bpy.data.volumes.new("blob")
    volume.filepath = str(vdb)
    assert volume.grids.load(), volume.grids.error_message
    assert sorted(g.name for g in volume.grids) == ["density", "value"]
    voxel, origin = expected_placement()
    for grid in volume.grids:
        assert grid.data_type == "FLOAT" and grid.channels == 1
        m = np.array([list(row) for row in grid.matrix_object])
        np.testing.assert_allclose(np.diag(m)[:3], voxel, rtol=1e-6)
        np.testing.assert_allclose(m[:3, 3], origin, atol=1e-6)
    obj = bpy.data.objects.new("blob", volume)
    bpy.context.scene.collection.objects.link(obj)
    bpy.context.view_layer.update()
    corners = np.array([list(c) for c in obj.bound_box])
    # Blender bounds a grid by its leaf nodes (8^3 voxels) holding active voxels, each voxel
    # extending half a voxel past its centre; the grids are padded by one voxel repeating the
    # border (index -1 and n).
    active = np.argwhere(np.pad(values, 1, mode="edge"))[:, ::-1] - 1  # x, y, z
    lo = origin + voxel * (active.min(0) // 8 * 8 - 0.5)
    hi = origin + voxel * (active.max(0) // 8 * 8 + 7.5)
    np.testing.assert_allclose(corners.min(0), lo, atol=1e-5)
    np.testing.assert_allclose(corners.max(0), hi, atol=1e-5)


def test_usd_stage_validates_and_points_at_the_grids(blob, tmp_path):
    from pxr import Usd, UsdGeom, UsdLux, UsdVol

    scene, _ = blob
    files = export(scene, tmp_path)
    stage = Usd.Stage.Open(str(files[".usda"]))
    assert usd_validation_errors(stage) == []
    assert UsdGeom.GetStageUpAxis(stage) == UsdGeom.Tokens.z
    assert UsdGeom.GetStageMetersPerUnit(stage) == 1.0
    assert stage.GetDefaultPrim().GetPath() == "/World"
    volume = UsdVol.Volume(stage.GetPrimAtPath("/World/Volume"))
    fields = volume.GetFieldPaths()
    assert sorted(fields) == ["density", "value"]
    for name, path in fields.items():
        asset = UsdVol.OpenVDBAsset(stage.GetPrimAtPath(path))
        assert asset.GetFieldNameAttr().Get() == name
        assert Path(asset.GetFilePathAttr().Get().resolvedPath) == files[".vdb"]
    camera = UsdGeom.Camera(stage.GetPrimAtPath("/World/Camera")).GetCamera()
    assert camera.GetFieldOfView(camera.FOVVertical) == pytest.approx(FOV_DEG, abs=1e-4)
    assert camera.aspectRatio == pytest.approx(SIZE[0] / SIZE[1], rel=1e-6)
    frame = camera.frustum
    assert np.allclose(frame.GetPosition(), (4.0, -3.0, 2.5), atol=1e-5)
    view = np.array(frame.ComputeViewDirection())
    want = np.array(CENTRE) - np.array((4.0, -3.0, 2.5))
    np.testing.assert_allclose(view, want / np.linalg.norm(want), atol=1e-6)
    sun = next(p for p in stage.Traverse() if p.IsA(UsdLux.DistantLight))
    to_world = UsdGeom.Xformable(sun).ComputeLocalToWorldTransform(0)
    shines = np.array(to_world.TransformDir((0, 0, -1)))
    to_light = np.array((-0.3, -1.0, 1.2))
    np.testing.assert_allclose(-shines, to_light / np.linalg.norm(to_light), atol=1e-6)
    kinds = sorted(p.GetTypeName() for p in stage.Traverse() if p.HasAPI(UsdLux.LightAPI))
    assert kinds == ["DistantLight", "DomeLight", "SphereLight"]


def test_blender_imports_the_stage(blob, tmp_path):
    import bpy

    scene, _ = blob
    files = export(scene, tmp_path)
    bpy.ops.wm.read_factory_settings(use_empty=True)
    assert bpy.ops.wm.usd_import(filepath=str(files[".usda"])) == {"FINISHED"}
    objects = {o.name: o for o in bpy.data.objects}
    volume = objects["Volume"]
    assert volume.type == "VOLUME"
    assert volume.data.grids.load(), volume.data.grids.error_message
    assert sorted(g.name for g in volume.data.grids) == ["density", "value"]
    camera = objects["Camera"]
    render = bpy.context.scene.render
    render.resolution_x, render.resolution_y = SIZE
    assert math.degrees(camera.data.angle_y) == pytest.approx(FOV_DEG, abs=1e-3)
    np.testing.assert_allclose(camera.matrix_world.translation, (4.0, -3.0, 2.5), atol=1e-5)
    suns = [o for o in bpy.data.objects if o.type == "LIGHT" and o.data.type == "SUN"]
    assert len(suns) == 1


@pytest.mark.parametrize("precision", [(), ("--float32",)])
def test_compositor_reads_each_exr_layer(blob, tmp_path, precision):
    import bpy

    scene, _ = blob
    exr = export(scene, tmp_path / "x", *precision)[".exr"]
    ours = oiio_read(exr)
    bpy.ops.wm.read_factory_settings(use_empty=True)
    image = bpy.data.images.load(str(exr))
    tree = bpy.data.node_groups.new("occlux", "CompositorNodeTree")
    tree.interface.new_socket("Image", in_out="OUTPUT", socket_type="NodeSocketColor")
    node = tree.nodes.new("CompositorNodeImage")
    node.image = image
    outputs = {o.name: o.type for o in node.outputs if o.enabled}
    assert outputs == {"beauty": "RGBA", "depth": "VALUE"}
    out = tree.nodes.new("NodeGroupOutput")
    blender_scene = bpy.context.scene
    blender_scene.compositing_node_group = tree
    camera = bpy.data.objects.new("camera", bpy.data.cameras.new("camera"))
    blender_scene.collection.objects.link(camera)
    blender_scene.camera = camera
    render = blender_scene.render
    render.engine = "BLENDER_WORKBENCH"  # the compositor is what is tested; the render is unused
    render.resolution_x, render.resolution_y = SIZE
    render.resolution_percentage = 100
    render.use_compositing = True
    render.image_settings.media_type = "IMAGE"
    render.image_settings.file_format = "OPEN_EXR"
    render.image_settings.color_depth = "32"
    for layer, channels in [("beauty", ["R", "G", "B"]), ("depth", ["Z"])]:
        for link in list(tree.links):
            tree.links.remove(link)
        tree.links.new(node.outputs[layer], out.inputs[0])
        render.filepath = str(tmp_path / f"composite-{layer}.exr")
        assert bpy.ops.render.render(write_still=True) == {"FINISHED"}
        composite = oiio_read(Path(render.filepath))
        for c in channels:
            got = composite["R"] if layer == "depth" else composite[c]
            want = ours[f"{layer}.{c}"]
            np.testing.assert_allclose(got, want, rtol=1e-6, err_msg=f"{layer}.{c}")
    assert ours["beauty.A"].max() > 0.5, "the blob is visible"


def test_export_of_a_real_ct(tmp_path, openvdb):
    engine = Path(__file__).parents[2] / "examples" / "engine.toml"
    nrrd = Path(__file__).parents[3] / "shared" / "data" / "scivis" / "engine.nrrd"
    assert nrrd.is_file(), f"{nrrd} is missing: CI runs with ../shared beside the project"
    from pxr import Usd

    files = export(engine, tmp_path, "--half")
    grids, _ = openvdb.readAll(str(files[".vdb"]))
    value = next(g for g in grids if g.name == "value")
    # 256 x 256 x 128 voxels with matter on every face, and the padding around them.
    assert tuple(value.evalActiveVoxelBoundingBox()[0]) == (-1, -1, -1)
    assert tuple(value.evalActiveVoxelBoundingBox()[1]) == (256, 256, 128)
    assert usd_validation_errors(Usd.Stage.Open(str(files[".usda"]))) == []


def test_export_failures_leave_no_files(blob, tmp_path):
    scene, _ = blob
    blocked = tmp_path / "file"
    blocked.write_text("not a folder")
    result = subprocess.run(
        [str(occlux_binary()), "export", str(scene), "-o", str(blocked / "out"), "--quiet"],
        capture_output=True,
        text=True,
    )
    assert result.returncode != 0
    assert "file" in result.stderr and "error" in result.stderr
    assert blocked.read_text() == "not a folder"


def test_an_all_transparent_classification_exports_an_empty_density_grid(blob, tmp_path, openvdb):
    # Every voxel's extinction is 0: the density grid holds no active voxel, which OpenVDB
    # reads as a valid, empty fog volume beside the value grid.
    scene, values = blob
    empty = tmp_path / "empty.toml"
    text = scene.read_text().replace("sigma_t = 30", "sigma_t = 0")
    empty.write_text(text.replace("blob.nrrd", str(scene.parent / "blob.nrrd")))
    files = export(empty, tmp_path / "out")
    grids, _ = openvdb.readAll(str(files[".vdb"]))
    by_name = {g.name: g for g in grids}
    assert sorted(by_name) == ["density", "value"]
    assert by_name["density"].activeVoxelCount() == 0
    assert by_name["density"].gridClass == "fog volume"
    np.testing.assert_allclose(
        by_name["density"].transform.voxelSize(), expected_placement()[0], rtol=1e-6
    )
    assert by_name["value"].activeVoxelCount() == np.count_nonzero(np.pad(values, 1, mode="edge"))


@pytest.mark.parametrize("half", [False, True])
def test_occlux_reads_what_openvdb_writes(tmp_path, openvdb, half):
    """A sparse grid written by OpenVDB 12 itself (Blosc and active-mask compression, the
    library's defaults, with tiles, internal-node values and scattered leaves) loads into the
    same dense values: the size checks in front of vdb-rs (vdb_sizes.rs) follow real files.
    Half floats in OpenVDB's own layout are refused by name."""
    import occlux

    rng = np.random.default_rng(7)
    dense = np.zeros((40, 24, 16), dtype=np.float32)  # x, y, z
    dense[3:37, 2:20, 1:15] = rng.uniform(0.5, 2.0, size=(34, 18, 14)).astype(np.float32)
    dense[10:18, 8:16, 0:8] = 3.0  # a constant block, pruned to a tile
    grid = openvdb.FloatGrid()
    grid.copyFromArray(dense, ijk=(0, 0, 0), tolerance=0.0)
    grid.prune()
    grid.name = "density"
    grid.transform = openvdb.createLinearTransform(voxelSize=0.5)
    if half:
        grid.saveFloatAsHalf = True
    path = tmp_path / "openvdb.vdb"
    openvdb.write(str(path), grids=[grid])
    scene = tmp_path / "scene.toml"
    camera = "[camera]\nposition = [0, -60, 0]\ntarget = [10, 6, 4]\n"
    scene.write_text(f'[volume]\npath = "{path}"\n{camera}')
    if half:
        # vdb-rs 0.6 fails on OpenVDB's own half-float layout (it reports an I/O error); the
        # size checks refuse it first, saying so, instead of letting it allocate.
        with pytest.raises(occlux.OccluxError, match="half-float grids that OpenVDB"):
            occlux.Scene.load(str(scene)).load_volume()
        return
    volume = occlux.Scene.load(str(scene)).load_volume()
    want = dense
    nz = np.argwhere(want)
    lo, hi = nz.min(0), nz.max(0) + 1
    got = volume.values  # (z, y, x) over the active bounding box
    np.testing.assert_array_equal(got, want[lo[0] : hi[0], lo[1] : hi[1], lo[2] : hi[2]].T)
    assert volume.spacing == pytest.approx((0.5, 0.5, 0.5))
