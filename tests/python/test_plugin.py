"""The Python package `occlux` (plugin/): numpy in and out, rendering on both devices, and the
files it writes read back by real readers (OpenImageIO and OpenVDB 12 from the bpy wheel)."""

from __future__ import annotations

import gc
import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import occlux
import pytest
from occlux_testing import oiio_read

BACKGROUND = (0.1, 0.2, 0.3)


def scene_text(
    volume: str = 'phantom = "ct"\nsize = 32',
    classification: str = 'preset = "ct-soft-tissue"\ndensity_scale = 0.5',
    size: tuple[int, int] = (40, 32),
) -> str:
    """A small scene: gradient shading, an ambient and a directional light."""
    return f"""
background = {list(BACKGROUND)}
[volume]
{volume}
[classification]
{classification}
[camera]
position = [3.0, -3.0, 2.5]
target = [0, 0, 0]
fov_deg = 40
width = {size[0]}
height = {size[1]}
[[lights]]
type = "ambient"
radiance = 0.3
[[lights]]
type = "directional"
direction = [-0.3, -1.0, 1.2]
irradiance = 2.0
[render]
method = "gradient"
"""


def random_values(shape: tuple[int, int, int], seed: int = 1) -> np.ndarray:
    """Values in [1, 2) with a zero (inactive in VDB) corner."""
    values = (1.0 + np.random.default_rng(seed).random(shape)).astype(np.float32)
    values[: shape[0] // 2, : shape[1] // 2, : shape[2] // 2] = 0.0
    return values


def nrrd_bytes(values: np.ndarray, spacing: tuple[float, float, float]) -> bytes:
    """A raw little-endian float NRRD of an array of shape (nz, ny, nx): x fastest, as C order."""
    nz, ny, nx = values.shape
    header = (
        f"NRRD0004\ntype: float\ndimension: 3\nsizes: {nx} {ny} {nz}\n"
        f"spacings: {' '.join(map(str, spacing))}\nencoding: raw\nendian: little\n\n"
    )
    return header.encode() + values.astype("<f4").tobytes()


# ---- numpy in and out ----


def test_volume_round_trips_float32_and_keeps_the_axis_order(tmp_path: Path) -> None:
    values = random_values((5, 6, 7))
    volume = occlux.Volume(values, spacing=(0.5, 1.0, 2.0), origin=(1.0, -2.0, 3.0))
    assert volume.dims == (7, 6, 5)
    np.testing.assert_array_equal(volume.values, values)
    # The core's bounding box: origin - spacing/2 .. origin + (dims - 1/2) * spacing, so x gets
    # the last numpy axis and z the first.
    lo, hi = volume.bounds
    np.testing.assert_allclose(lo, (0.75, -2.5, 2.0))
    np.testing.assert_allclose(hi, (1.0 + 6.5 * 0.5, -2.0 + 5.5, 3.0 + 4.5 * 2.0))
    assert volume.value_range == (float(values.min()), float(values.max()))
    # The core's NRRD loader (x fastest in the file) gives the same array.
    (tmp_path / "v.nrrd").write_bytes(nrrd_bytes(values, (0.5, 1.0, 2.0)))
    loaded = occlux.Volume.load(tmp_path / "v.nrrd")
    assert loaded.dims == (7, 6, 5)
    np.testing.assert_allclose(loaded.spacing, (0.5, 1.0, 2.0))
    np.testing.assert_array_equal(loaded.values, values)


def test_value_range_follows_a_slice_along_z() -> None:
    values = np.arange(4 * 3 * 2, dtype=np.float32).reshape(4, 3, 2)  # (nz, ny, nx)
    volume = occlux.Volume(values[2:3])  # the plane z = 2: values 12 .. 17
    assert volume.dims == (2, 3, 1)
    assert volume.value_range == (12.0, 17.0)


@pytest.mark.parametrize(
    "dtype", ["uint8", "int16", "uint16", "int32", "int64", "float64", "float16", ">f4"]
)
def test_any_real_dtype_becomes_float32(dtype: str) -> None:
    values = (np.arange(60).reshape(3, 4, 5) % 17).astype(dtype)
    volume = occlux.Volume(values)
    assert volume.values.dtype == np.float32
    np.testing.assert_array_equal(volume.values, values.astype(np.float32))


def test_strided_and_fortran_arrays_are_read_in_logical_order() -> None:
    base = np.random.default_rng(2).random((6, 8, 10))
    for values in (base[::2, 1::3, ::-1], np.asfortranarray(base), base.astype(np.float32).T):
        np.testing.assert_array_equal(occlux.Volume(values).values, values.astype(np.float32))


def test_values_is_a_read_only_view_that_keeps_the_volume_alive() -> None:
    volume = occlux.Volume(random_values((4, 4, 4)))
    first, second = volume.values, volume.values
    assert np.shares_memory(first, second)
    assert not first.flags.writeable
    with pytest.raises(ValueError, match="read-only"):
        first[0, 0, 0] = 5.0
    expected = first.copy()
    del volume, second
    gc.collect()
    np.testing.assert_array_equal(first, expected)


def test_phantoms_fill_the_unit_cube() -> None:
    volume = occlux.Volume.phantom("sphere", size=16)
    assert volume.dims == (16, 16, 16)
    np.testing.assert_allclose(volume.bounds, ((-1, -1, -1), (1, 1, 1)), atol=1e-6)
    assert volume.value_range == (0.0, 1.0)
    assert "sphere" in occlux.PHANTOMS and "ct-bone" in occlux.PRESETS


def test_scene_resolves_its_volume_path_and_takes_a_classification(tmp_path: Path) -> None:
    values = random_values((6, 5, 4))
    np.save(tmp_path / "v.npy", values)
    path = tmp_path / "s.toml"
    path.write_text(scene_text(volume='path = "v.npy"'))
    scene = occlux.Scene.load(path)
    np.testing.assert_array_equal(scene.load_volume().values, values)
    assert (scene.width, scene.height) == (40, 32)
    assert scene.background == pytest.approx(BACKGROUND)
    clear = occlux.Classification.from_points(
        [(0.0, 0.0, (1, 1, 1), (0, 0, 0)), (1.0, 0.0, (1, 1, 1), (0, 0, 0))], units="normalized"
    )
    scene.classification = clear
    assert scene.classification.units == "normalized"
    # Nothing absorbs any more: the image is the background.
    image = occlux.render(scene, device="cpu").beauty
    np.testing.assert_allclose(image[..., :3], np.broadcast_to(BACKGROUND, image[..., :3].shape))
    assert np.all(image[..., 3] == 0.0)


# ---- rendering ----


def test_cpu_and_gpu_renders_agree(gpu_device: str) -> None:
    scene = occlux.Scene.from_toml(scene_text(size=(48, 40)))
    volume = scene.load_volume()
    cpu = occlux.render(scene, volume, device="cpu")
    gpu = occlux.render(scene, volume, device=gpu_device)
    assert cpu.device == "cpu" and gpu.device not in ("", "cpu")
    assert cpu.beauty.shape == gpu.beauty.shape == (40, 48, 4)
    assert cpu.depth.shape == (40, 48)
    assert cpu.beauty[..., 3].max() > 0.5  # the phantom is in view
    diff = np.abs(cpu.beauty - gpu.beauty).max(axis=2)
    peak = max(1.0, float(cpu.beauty[..., :3].max()))
    # The twins' tolerance in tests/raycast_twins.rs: 1e-3 of the peak, 0.5 % outliers.
    assert np.mean(diff > 1e-3 * peak) <= 0.005, f"max difference {diff.max()}"
    assert diff.max() < 0.05 * peak


def test_an_empty_volume_renders_the_background() -> None:
    scene = occlux.Scene.from_toml(scene_text(size=(16, 12)))
    result = occlux.render(scene, occlux.Volume(np.zeros((8, 8, 8))), device="cpu")
    assert (result.width, result.height) == (16, 12)
    rgb = result.beauty[..., :3]
    np.testing.assert_array_equal(rgb, np.broadcast_to(np.float32(BACKGROUND), rgb.shape))
    assert np.all(result.beauty[..., 3] == 0.0)
    assert np.all(result.depth == 1e10)


def test_set_size_changes_the_image_and_progress_reports_every_row() -> None:
    scene = occlux.Scene.from_toml(scene_text())
    scene.set_size(24, 16)
    reports: list[tuple[int, int]] = []
    result = occlux.render(scene, device="cpu", progress=lambda d, t: reports.append((d, t)))
    assert result.beauty.shape == (16, 24, 4)
    assert reports and max(reports) == (16, 16)
    with pytest.raises(occlux.OccluxError, match=r"camera\.width"):
        scene.set_size(0, 16)


def test_an_exception_in_the_progress_callback_reaches_the_caller() -> None:
    scene = occlux.Scene.from_toml(scene_text(size=(8, 8)))

    def fail(done: int, total: int) -> None:
        raise KeyError("stop")

    with pytest.raises(KeyError, match="stop"):
        occlux.render(scene, device="cpu", progress=fail)


# ---- files, read back by real readers ----


@pytest.mark.parametrize("float32", [False, True])
def test_write_exr_reads_back_in_openimageio(tmp_path: Path, oiio, float32: bool) -> None:
    scene = occlux.Scene.from_toml(scene_text(size=(40, 24)))
    result = occlux.render(scene, device="cpu")
    path = tmp_path / "render.exr"
    occlux.write_exr(path, result, scene, float32=float32)
    channels = oiio_read(path)
    expected = result.beauty if float32 else result.beauty.astype(np.float16).astype(np.float32)
    for c, name in enumerate("RGBA"):
        np.testing.assert_array_equal(channels[f"beauty.{name}"], expected[..., c])
    np.testing.assert_array_equal(channels["depth.Z"], result.depth)
    image = oiio.ImageInput.open(str(path))
    try:
        spec = image.spec()
        camera = json.loads(spec.getattribute("occlux/camera"))
    finally:
        image.close()
    assert (spec.width, spec.height) == (40, 24)
    assert (camera["width"], camera["height"]) == (40, 24)
    assert camera["position"] == pytest.approx([3.0, -3.0, 2.5])


@pytest.mark.parametrize("compression", ["zip", "none"])
def test_write_vdb_reads_back_in_openvdb(tmp_path: Path, openvdb, compression: str) -> None:
    volumes = {
        "density": occlux.Volume(
            random_values((6, 5, 9)), spacing=(0.5, 1.0, 2.0), origin=(1.0, -2.0, 3.0)
        ),
        "ao": occlux.Volume(random_values((4, 7, 3), seed=3), spacing=(0.25, 0.25, 0.25)),
    }
    path = tmp_path / "grids.vdb"
    occlux.write_vdb(path, volumes, compression=compression)
    grids = {grid.name: grid for grid in openvdb.readAll(str(path))[0]}
    assert sorted(grids) == sorted(volumes)
    for name, volume in volumes.items():
        grid = grids[name]
        assert grid.transform.voxelSize() == pytest.approx(volume.spacing)
        assert grid.transform.indexToWorld((0, 0, 0)) == pytest.approx(volume.origin)
        assert grid.gridClass == openvdb.GridClass.FOG_VOLUME
        # One voxel of padding on every side repeats the border (src/export/vdb.rs).
        assert grid.activeVoxelCount() == np.count_nonzero(np.pad(volume.values, 1, mode="edge"))
        read = np.zeros(volume.dims, np.float32)  # indexed [i, j, k]
        grid.copyToArray(read, ijk=(0, 0, 0))
        np.testing.assert_array_equal(read, volume.values.transpose(2, 1, 0))


def test_write_vdb_half_rounds_to_float16(tmp_path: Path, openvdb) -> None:
    volume = occlux.Volume(random_values((5, 4, 3)) * 1.2345)
    path = tmp_path / "half.vdb"
    occlux.write_vdb(path, {"density": volume}, half=True)
    (grid,), _ = openvdb.readAll(str(path))
    assert grid.saveFloatAsHalf
    read = np.zeros(volume.dims, np.float32)
    grid.copyToArray(read)
    expected = volume.values.astype(np.float16).astype(np.float32).transpose(2, 1, 0)
    np.testing.assert_array_equal(read, expected)


def test_write_vdb_stores_the_named_grids_as_half_floats(tmp_path: Path, openvdb) -> None:
    """`half` as grid names: those grids float16 (rounded as numpy rounds), the others float32
    (exact), in one file; a name that is not a grid is refused."""
    volume = occlux.Volume(random_values((5, 4, 3)) * 1.2345)
    path = tmp_path / "mixed.vdb"
    occlux.write_vdb(path, {"ao": volume, "density": volume}, half=["ao"])
    grids = {grid.name: grid for grid in openvdb.readAll(str(path))[0]}
    assert grids["ao"].saveFloatAsHalf and not grids["density"].saveFloatAsHalf
    for name, dtype in (("ao", np.float16), ("density", np.float32)):
        read = np.zeros(volume.dims, np.float32)
        grids[name].copyToArray(read)
        expected = volume.values.astype(dtype).astype(np.float32).transpose(2, 1, 0)
        np.testing.assert_array_equal(read, expected)
    with pytest.raises(occlux.OccluxError, match="no grid 'sdf' to store as float16"):
        occlux.write_vdb(tmp_path / "refused.vdb", {"ao": volume}, half=["sdf"])


# ---- errors ----


def test_nan_is_an_occlux_error_naming_the_voxel() -> None:
    values = np.ones((4, 3, 2), np.float32)
    values[3, 1, 0] = np.nan  # voxel (i, j, k) = (0, 1, 3)
    with pytest.raises(occlux.OccluxError, match=r"value NaN at voxel \[0, 1, 3\] is not finite"):
        occlux.Volume(values)


@pytest.mark.parametrize(
    ("values", "error"),
    [
        (np.ones((4, 4)), ValueError),
        (np.ones((2, 2, 2, 2)), ValueError),
        (np.ones((2, 2, 2), bool), TypeError),
        (np.ones((2, 2, 2), complex), TypeError),
        ([[[1.0]]], TypeError),
    ],
)
def test_arrays_of_the_wrong_shape_or_dtype_are_rejected(values, error: type) -> None:
    with pytest.raises(error):
        occlux.Volume(values)


def test_bad_arguments_raise_the_core_message() -> None:
    with pytest.raises(occlux.OccluxError, match=r"invalid `classification\.preset`: unknown"):
        occlux.Classification.preset("ct-bones")
    with pytest.raises(occlux.OccluxError, match="unknown phantom 'cube'"):
        occlux.Volume.phantom("cube")
    with pytest.raises(occlux.OccluxError, match="invalid `units`: 'kelvin' is not one of"):
        occlux.Classification.preset("mri", units="kelvin")  # type: ignore[arg-type]
    with pytest.raises(occlux.OccluxError, match="'mri' has no form in Hounsfield units"):
        occlux.Classification.preset("mri", units="hu")
    with pytest.raises(occlux.OccluxError, match="spacing must be positive"):
        occlux.Volume(np.ones((2, 2, 2)), spacing=(1.0, 0.0, 1.0))
    with pytest.raises(occlux.OccluxError, match=r"classification\.density_scale"):
        occlux.Classification.preset("mri", density_scale=-1.0)
    with pytest.raises(occlux.OccluxError, match=r"camera\.width"):
        occlux.Scene.from_toml(scene_text(size=(0, 4)))
    with pytest.raises(occlux.OccluxError, match="invalid `device`"):
        occlux.render(occlux.Scene.from_toml(scene_text()), device="tpu")


def test_a_truncated_file_is_an_occlux_error_naming_it(tmp_path: Path) -> None:
    path = tmp_path / "short.nrrd"
    path.write_bytes(nrrd_bytes(random_values((4, 4, 4)), (1, 1, 1))[:-10])
    with pytest.raises(occlux.OccluxError, match=r"short\.nrrd"):
        occlux.Volume.load(path)


def test_failed_writes_leave_no_file(tmp_path: Path) -> None:
    scene = occlux.Scene.from_toml(scene_text(size=(8, 8)))
    result = occlux.render(scene, device="cpu")
    volume = occlux.Volume(random_values((4, 4, 4)))
    missing = tmp_path / "no" / "such" / "dir"
    with pytest.raises(occlux.OccluxError, match="no/such/dir"):
        occlux.write_exr(missing / "a.exr", result, scene)
    with pytest.raises(occlux.OccluxError, match="no/such/dir"):
        occlux.write_vdb(missing / "a.vdb", {"density": volume})
    # The target is a folder: the temporary file is written, the rename fails, and the
    # temporary file must be gone.
    folder = tmp_path / "taken"
    folder.mkdir()
    with pytest.raises(occlux.OccluxError):
        occlux.write_exr(folder, result, scene)
    with pytest.raises(occlux.OccluxError):
        occlux.write_vdb(folder, {"density": volume})
    with pytest.raises(occlux.OccluxError, match="does not fit a half float"):
        huge = occlux.Volume(np.full((2, 2, 2), 1e6, dtype=np.float32))
        occlux.write_vdb(tmp_path / "huge.vdb", {"density": huge}, half=True)
    with pytest.raises(occlux.OccluxError, match="invalid `compression`"):
        occlux.write_vdb(tmp_path / "bad.vdb", {"density": volume}, compression="lzma")
    with pytest.raises(TypeError):
        occlux.write_vdb(tmp_path / "bad.vdb", {"density": volume.values})
    assert sorted(p.name for p in tmp_path.rglob("*")) == ["taken"]
    assert list(folder.iterdir()) == []


# ---- Blender ----


def test_blender_python_imports_bpy_and_occlux_together() -> None:
    script = (
        "import bpy, numpy as np, occlux\n"
        "v = occlux.Volume(np.arange(24, dtype=np.float32).reshape(2, 3, 4))\n"
        "print(bpy.app.version_string, v.dims, v.value_range)\n"
    )
    done = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    assert done.stdout.split()[0].startswith("5.0")
    assert "(4, 3, 2) (0.0, 23.0)" in done.stdout


# ---- ambient-occlusion volumes ----


def test_ao_volume_twins_agree_and_read_back_in_openvdb(
    tmp_path: Path, openvdb, gpu_device: str
) -> None:
    scene = occlux.Scene.from_toml(scene_text())
    volume = scene.load_volume()
    cpu = occlux.ao_volume(scene, method="gauss", radius=3, variance=True, device="cpu")
    gpu = occlux.ao_volume(scene, method="gauss", radius=3, variance=True, device=gpu_device)
    assert sorted(cpu) == ["ao", "ao_variance"]
    ao = cpu["ao"].values
    assert ao.shape == volume.values.shape
    assert 0.0 <= ao.min() and ao.max() <= 1.0 and ao.max() > ao.min()
    # The twins' tolerance in tests/vao.rs (Winitzki's erf rounds differently on the GPU).
    np.testing.assert_allclose(gpu["ao"].values, ao, atol=2e-3)
    path = tmp_path / "ao.vdb"
    occlux.write_vdb(path, cpu)
    grids = {grid.name: grid for grid in openvdb.readAll(str(path))[0]}
    read = np.zeros(cpu["ao"].dims, np.float32)
    grids["ao"].copyToArray(read)
    np.testing.assert_array_equal(read, ao.transpose(2, 1, 0))


def test_bake_holds_the_visibility_and_each_light_and_reads_back_in_openvdb(
    tmp_path: Path, openvdb
) -> None:
    scene = occlux.Scene.from_toml(scene_text())
    volume = scene.load_volume()
    baked = occlux.bake(scene, directions=16, g=0.3, device="cpu")
    # Ambient light is the visibility and its multiple scattering; the sun is light 0.
    assert list(baked) == [
        "ao",
        "ao_multiple_r",
        "ao_multiple_g",
        "ao_multiple_b",
        "light0",
        "light0_multiple_r",
        "light0_multiple_g",
        "light0_multiple_b",
    ]
    ao = occlux.ao_volume(scene, directions=16, device="cpu")["ao"].values
    np.testing.assert_array_equal(baked["ao"].values, ao)
    reaching = baked["light0"].values
    assert reaching.shape == volume.values.shape
    # Per unit irradiance: 1 where nothing lies between a voxel and the sun, less behind matter.
    assert 0.0 < reaching.min() < 0.5 and reaching.max() == pytest.approx(1.0, abs=1e-6)
    for name in ("light0_multiple_r", "ao_multiple_g"):
        multiple = baked[name].values
        assert np.isfinite(multiple).all() and multiple.min() >= 0.0 and multiple.max() > 0.0
    path = tmp_path / "bake.vdb"
    occlux.write_vdb(path, baked)
    grids = {grid.name: grid for grid in openvdb.readAll(str(path))[0]}
    read = np.zeros(baked["light0"].dims, np.float32)
    grids["light0"].copyToArray(read)
    np.testing.assert_array_equal(read, reaching.transpose(2, 1, 0))
    with pytest.raises(occlux.OccluxError, match="directions"):
        occlux.bake(scene, directions=0, device="cpu")
    with pytest.raises(occlux.OccluxError, match="cancelled"):
        occlux.bake(scene, device="cpu", progress=lambda done, total: False)


def test_ao_volume_refuses_bad_arguments_and_cancels() -> None:
    scene = occlux.Scene.from_toml(scene_text())
    with pytest.raises(occlux.OccluxError, match="median"):
        occlux.ao_volume(scene, method="median", device="cpu")
    with pytest.raises(occlux.OccluxError, match="radius"):
        occlux.ao_volume(scene, method="cdf", radius=0, device="cpu")
    with pytest.raises(occlux.OccluxError, match="directions"):
        occlux.ao_volume(scene, directions=0, device="cpu")
    # The default method (the discrete ordinates) reaches the whole volume: a radius is refused
    # rather than ignored.
    with pytest.raises(occlux.OccluxError, match=r"radius.*ordinates would ignore it"):
        occlux.ao_volume(scene, radius=3, device="cpu")
    with pytest.raises(occlux.OccluxError, match="cancelled"):
        occlux.ao_volume(scene, device="cpu", progress=lambda done, total: False)


def test_ao_volume_by_the_physical_sweep_is_a_visibility_of_the_extinction() -> None:
    scene = occlux.Scene.from_toml(scene_text())
    volume = scene.load_volume()
    swept = occlux.ao_volume(scene, method="sweep-physical", device="cpu")
    assert sorted(swept) == ["ao"]
    ao = swept["ao"].values
    extinction = scene.classification.extinction(volume).values
    # Where there is no matter light is lost only further out; inside matter, visibility drops.
    assert 0.0 <= ao.min() and ao.max() <= 1.0
    assert ao[extinction > 0].mean() < ao[extinction == 0].mean()
    # The sweep reads the extinction and computes no variance.
    with pytest.raises(occlux.OccluxError, match="field"):
        occlux.ao_volume(scene, method="sweep-physical", field="value", device="cpu")
    with pytest.raises(occlux.OccluxError, match="variance"):
        occlux.ao_volume(scene, method="sweep-physical", variance=True, device="cpu")
    # The registry offers both sweeps to every reader (the add-on's Compute AO among them).
    entry = next(m for m in occlux.methods() if m["name"] == "ao")
    ao_method = next(p for p in entry["params"] if p["key"] == "ao_method")
    names = [o["name"] for o in ao_method["options"]]
    assert "sweep" in names and "sweep-physical" in names


def test_ao_volume_by_occlusion_sweeping_writes_a_level_set_and_octants(
    tmp_path: Path, openvdb
) -> None:
    scene = occlux.Scene.from_toml(scene_text())
    grids = occlux.ao_volume(scene, method="sweep", iso=0.5, octants=True, gamma=1.0)
    assert list(grids) == ["ao", "sdf"] + [f"ao_oct{s}" for s in range(8)]
    sdf, ao = grids["sdf"].values, grids["ao"].values
    volume = scene.load_volume().values
    # Negative inside (values above the iso-value), positive outside.
    assert (sdf[volume > 0.5] <= 0).all() and (sdf[volume <= 0.5] >= 0).all()
    assert 0.0 <= ao.min() and ao.max() <= 1.0
    # Gamma 2 (the default) is the square root of gamma 1.
    brighter = occlux.ao_volume(scene, method="sweep", iso=0.5)["ao"].values
    np.testing.assert_allclose(brighter, np.sqrt(ao), atol=1e-5)
    # The signed distance is a level set in OpenVDB, with its values.
    path = tmp_path / "swept.vdb"
    occlux.write_vdb(path, grids)
    read = {grid.name: grid for grid in openvdb.readAll(str(path))[0]}
    assert read["sdf"].gridClass == openvdb.GridClass.LEVEL_SET
    assert read["ao"].gridClass == openvdb.GridClass.FOG_VOLUME
    dense = np.zeros(grids["sdf"].dims, np.float32)  # indexed [i, j, k]
    read["sdf"].copyToArray(dense, ijk=(0, 0, 0))
    np.testing.assert_array_equal(dense, sdf.transpose(2, 1, 0))
    # Bad input is named.
    with pytest.raises(occlux.OccluxError, match="octant_intensities"):
        occlux.ao_volume(scene, method="sweep", octant_intensities=[1, 1])
    with pytest.raises(occlux.OccluxError, match="never crosses"):
        occlux.ao_volume(scene, method="sweep", iso=5.0)
    with pytest.raises(occlux.OccluxError, match="octants"):
        occlux.ao_volume(scene, method="sweep-physical", octants=True)


def test_dos_renders_expose_the_occlusion_layer_and_other_methods_none() -> None:
    # DOS is lit by ambient light only: the scene up to its directional light, then DOS.
    ambient_only = scene_text(size=(24, 20)).split('[[lights]]\ntype = "directional"')[0]
    dos = ambient_only + '[render]\nmethod = "dos"\ntheta_deg = 60\ngrid = 3\n'
    result = occlux.render(occlux.Scene.from_toml(dos), device="cpu")
    layer = result.occlusion
    assert layer is not None and layer.shape == (20, 24, 2) and not layer.flags.writeable
    # (P, A): the occlusion premultiplied by coverage, and the coverage, which is the alpha.
    occlusion, coverage = layer[..., 0], layer[..., 1]
    np.testing.assert_array_equal(coverage, result.beauty[..., 3])
    assert occlusion.min() >= 0.0 and (occlusion <= coverage).all()
    # Where the volume is opaque the cone sees occluders; where the ray meets nothing, P = A = 0.
    opaque = coverage >= 0.5
    assert opaque.any() and (occlusion[opaque] / coverage[opaque]).mean() < 0.95
    empty = coverage == 0.0
    assert empty.any() and (occlusion[empty] == 0.0).all()
    gradient = occlux.render(occlux.Scene.from_toml(scene_text(size=(8, 8))), device="cpu")
    assert gradient.occlusion is None


def test_ipsvi_renders_shadows_that_agree_with_the_single_scattering_reference() -> None:
    # The scene's sun alone (IPSVI renders suns and lamps, not ambient light).
    sun_only = scene_text(size=(32, 32)).replace(
        'type = "ambient"\nradiance = 0.3\n[[lights]]\n', ""
    )
    ipsvi = sun_only.replace('method = "gradient"', 'method = "ipsvi"')
    scene = occlux.Scene.from_toml(ipsvi)
    result = occlux.render(scene, device="cpu")
    layer = result.shadow
    assert layer is not None and layer.shape == (32, 32, 2) and result.occlusion is None
    shadow, coverage = layer[..., 0], layer[..., 1]
    np.testing.assert_array_equal(coverage, result.beauty[..., 3])
    assert shadow.min() >= 0.0 and (shadow <= coverage).all()
    opaque = coverage >= 0.5
    assert opaque.any() and (shadow[opaque] / coverage[opaque] < 0.5).any(), (
        "the phantom shadows itself"
    )
    np.testing.assert_array_equal(shadow[coverage == 0.0], 0.0)
    # Against the Monte Carlo single-scattering reference of the same scene: the method's error
    # (a few percent, tests/ipsvi.rs) is far below what dropping the shadows does.
    reference = occlux.reference(scene, estimator="single", spp=64, seed=3)
    truth = reference.mean[..., :3]
    lit = truth.mean(axis=2) > 0
    error = np.sqrt(np.mean((result.beauty[..., :3] - truth)[lit] ** 2)) / truth[lit].mean()
    unshadowed = occlux.render(
        occlux.Scene.from_toml(sun_only.replace('method = "gradient"', 'method = "unshaded"')),
        device="cpu",
    )
    no_shadow = np.sqrt(np.mean((unshadowed.beauty[..., :3] - truth)[lit] ** 2)) / truth[lit].mean()
    assert error < 0.05 and no_shadow > 4 * error, (error, no_shadow)
    with pytest.raises(occlux.OccluxError, match="ambient"):
        occlux.render(occlux.Scene.from_toml(scene_text().replace("gradient", "ipsvi")))


def test_an_auto_scene_renders_the_planners_choice_and_says_so(tmp_path: Path, oiio) -> None:
    text = scene_text(size=(32, 24)).replace(
        'method = "gradient"', 'method = "auto"\nerror = 0.2\npilot = 16'
    )
    scene = occlux.Scene.from_toml(text)
    result = occlux.render(scene, device="cpu")
    plan = json.loads(result.plan)
    assert plan["budget"]["error"] == 0.2
    assert plan["predicted_error"] <= 0.2
    # Both lights, single scattering: the random walk at 0 bounces is the truth.
    assert plan["truth"] == "multiple"
    assert np.isfinite(result.beauty).all()
    path = tmp_path / "auto.exr"
    occlux.write_exr(path, result, scene)
    image = oiio.ImageInput.open(str(path))
    try:
        spec = image.spec()
        header_plan = json.loads(spec.getattribute("occlux/plan"))
        header_method = json.loads(spec.getattribute("occlux/method"))
    finally:
        image.close()
    assert header_plan == plan
    assert header_method == plan["method"]
    # A scene with a fixed method has no plan.
    assert occlux.render(occlux.Scene.from_toml(scene_text(size=(8, 8))), device="cpu").plan is None


def test_volume_histogram_bins_as_numpy_and_the_robust_window_is_the_cores() -> None:
    """The bindings without Blender: `Volume.histogram` bins as numpy does (values on the
    edges included), `Volume.robust_window` gives the window with the ramp `occlux info
    --suggest` suggests on it (ending at the window's top), and bad bins or ranges are refused
    by name."""
    rng = np.random.default_rng(7)
    values = np.concatenate([rng.normal(100.0, 30.0, 30_000), np.arange(0, 256, 0.25)])
    values = values.astype(np.float32).reshape(2, 1, -1)
    volume = occlux.Volume(values)
    for lo, hi, bins in ((0.0, 255.0, 64), (40.0, 160.0, 7), (-3.5, 300.25, 1000)):
        want, _ = np.histogram(values.astype(np.float64), bins=bins, range=(lo, hi))
        got = volume.histogram(lo, hi, bins)
        assert got.dtype == np.uint64
        np.testing.assert_array_equal(got, want)
    robust = volume.robust_window()
    assert robust["lo"] < robust["hi"] and robust["cut"] is None
    assert robust["points"][-1][0] == robust["hi"] and len(robust["points"]) == 3
    for bins in (0, -2, 70_000):
        with pytest.raises(occlux.OccluxError, match=r"histogram\.bins"):
            volume.histogram(0.0, 1.0, bins)
    for lo, hi in ((1.0, 1.0), (2.0, 1.0), (float("nan"), 1.0), (0.0, float("inf"))):
        with pytest.raises(occlux.OccluxError, match=r"histogram\.range"):
            volume.histogram(lo, hi)
