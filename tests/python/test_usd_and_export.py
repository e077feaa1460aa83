"""The package's exports: `occlux.export`, the pxr-authored stage of `occlux.usd` (the same stage
as the core's `.usda`, valid, imported by Blender, composable into another stage) and the Monte
Carlo references through `occlux.reference`."""

from __future__ import annotations

import json
import os
from pathlib import Path

import numpy as np
import occlux
import occlux.usd
import pytest
from occlux_testing import oiio_read, run_occlux, usd_validation_errors

SCENE = """
background = 0.1
[volume]
phantom = "shells"
size = 24
[classification]
points = [
  { value = 0.0, sigma_t = 0, albedo = [0.9, 0.7, 0.5] },
  { value = 1.0, sigma_t = 12, albedo = [0.6, 0.8, 0.9] },
]
[camera]
position = [2.5, -3.0, 1.5]
target = [0, 0, 0]
fov_deg = 35
width = 24
height = 16
[[lights]]
type = "ambient"
radiance = 0.4
[[lights]]
type = "directional"
direction = [0.2, -1.0, 1.0]
irradiance = 2.0
[[lights]]
type = "point"
position = [0.5, 1.5, 2.0]
intensity = 3.0
"""
GRIDS = ["density", "value"]


@pytest.fixture
def scene(tmp_path: Path) -> tuple[occlux.Scene, Path]:
    path = tmp_path / "shells.toml"
    path.write_text(SCENE)
    return occlux.Scene.load(path), path


def authored(stage) -> dict[str, dict[str, object]]:
    """Every prim's type, authored attribute values and relationship targets, by path."""
    prims = {}
    for prim in stage.Traverse():
        fields: dict[str, object] = {"type": prim.GetTypeName()}
        for attr in prim.GetAuthoredAttributes():
            fields[attr.GetName()] = attr.Get()
        for rel in prim.GetAuthoredRelationships():
            fields[rel.GetName()] = [str(t) for t in rel.GetTargets()]
        prims[str(prim.GetPath())] = fields
    return prims


def assert_same_value(a: object, b: object, where: str) -> None:
    from pxr import Sdf, Vt

    if isinstance(a, Sdf.AssetPath):
        assert a.path == b.path, where
    elif isinstance(a, str | list | bool | Vt.TokenArray) or a is None:
        assert list(a) == list(b) if isinstance(a, Vt.TokenArray) else a == b, where
    else:  # numbers, Gf vectors and matrices: float32 text vs double authoring
        np.testing.assert_allclose(np.array(a, float), np.array(b, float), rtol=1e-6, err_msg=where)


def test_pxr_authoring_gives_the_cores_stage(scene, tmp_path: Path) -> None:
    from pxr import Usd, UsdGeom

    s, _ = scene
    written = occlux.export(s, tmp_path, stem="shells", device="cpu")
    assert sorted(Path(p).name for p in written) == [
        "shells.exr",
        "shells.png",
        "shells.usda",
        "shells.vdb",
    ]
    volume = s.load_volume()
    description = occlux.stage_description(s, volume, "shells.vdb", GRIDS)
    occlux.usd.write_stage(tmp_path / "pxr.usda", description)
    core = Usd.Stage.Open(str(tmp_path / "shells.usda"))
    ours = Usd.Stage.Open(str(tmp_path / "pxr.usda"))
    assert usd_validation_errors(ours) == []
    a, b = authored(core), authored(ours)
    assert sorted(a) == sorted(b)
    for path, fields in a.items():
        assert sorted(fields) == sorted(b[path]), path
        for name, value in fields.items():
            assert_same_value(value, b[path][name], f"{path}.{name}")
    for stage in (core, ours):
        assert UsdGeom.GetStageUpAxis(stage) == "Z"
        assert UsdGeom.GetStageMetersPerUnit(stage) == 1.0
        assert stage.GetMetadata("renderSettingsPrimPath") == "/Render/Settings"
    assert len(a) >= 9, "volume, two fields, camera, three lights, render settings"


@pytest.mark.parametrize("stage", ["shells.usda", "pxr.usdc"])
def test_blender_imports_the_stage_without_stray_empties(scene, tmp_path: Path, stage) -> None:
    """Blender's own USD import (File > Import > USD): the volume with its grids and the lights;
    the root is the one empty, none for the field prims or the render settings' parent."""
    import bpy

    s, _ = scene
    occlux.export(s, tmp_path, stem="shells", device="cpu")
    description = json.loads(occlux.stage_description(s, s.load_volume(), "shells.vdb", GRIDS))
    occlux.usd.write_stage(tmp_path / "pxr.usdc", description)
    bpy.ops.wm.read_factory_settings(use_empty=True)
    assert bpy.ops.wm.usd_import(filepath=str(tmp_path / stage)) == {"FINISHED"}
    volume = bpy.data.objects["Volume"]
    assert volume.data.grids.load(), volume.data.grids.error_message
    assert sorted(g.name for g in volume.data.grids) == GRIDS
    types = sorted(o.data.type for o in bpy.data.objects if o.type == "LIGHT")
    assert "SUN" in types and "POINT" in types
    assert [o.name for o in bpy.data.objects if o.type == "EMPTY"] == ["World"]


def test_add_to_stage_keeps_the_pipelines_prims(scene, tmp_path: Path) -> None:
    from pxr import Usd, UsdGeom

    s, _ = scene
    stage = Usd.Stage.CreateInMemory()
    UsdGeom.Xform.Define(stage, "/Shot")
    stage.SetDefaultPrim(stage.GetPrimAtPath("/Shot"))
    UsdGeom.Sphere.Define(stage, "/Shot/Prop")
    description = occlux.stage_description(s, s.load_volume(), "shells.vdb", ["density"])
    occlux.usd.add_to_stage(stage, description)
    assert stage.GetPrimAtPath("/Shot/Prop").IsValid()
    assert str(stage.GetDefaultPrim().GetPath()) == "/Shot", "an existing default prim stays"
    assert stage.GetPrimAtPath("/World/Volume/density").GetTypeName() == "OpenVDBAsset"


def test_bad_stage_requests_are_clear_errors(scene, tmp_path: Path) -> None:
    s, _ = scene
    volume = s.load_volume()
    with pytest.raises(occlux.OccluxError, match="cannot name a USD prim"):
        occlux.stage_description(s, volume, "v.vdb", ["2density"])
    description = occlux.stage_description(s, volume, "v.vdb", ["density"])
    missing = tmp_path / "no" / "such" / "folder" / "x.usda"
    with pytest.raises(occlux.OccluxError, match="does not exist"):
        occlux.usd.write_stage(missing, description)
    with pytest.raises(occlux.OccluxError, match="plain file name"):
        occlux.export(s, tmp_path, stem="a/b", device="cpu")
    assert list(tmp_path.iterdir()) == [tmp_path / "shells.toml"], "nothing was written"


def test_the_exported_density_grid_is_the_classified_extinction(scene, tmp_path, openvdb) -> None:
    s, _ = scene
    occlux.export(s, tmp_path, stem="shells", device="cpu")
    volume = s.load_volume()
    want = s.classification.extinction(volume).values
    grid = openvdb.read(str(tmp_path / "shells.vdb"), "density")
    dense = np.zeros(volume.dims, dtype=np.float32)
    grid.copyToArray(dense, ijk=(0, 0, 0))
    np.testing.assert_array_equal(dense.transpose(2, 1, 0), want)
    # The transfer function's ramp: 12 sigma_t per unit at the volume's maximum value.
    assert want.max() == pytest.approx(12.0, rel=1e-6)


@pytest.mark.parametrize("estimator", ["ambient", "single", "multiple", "cone"])
def test_reference_is_the_clis_reference(scene, tmp_path: Path, estimator: str) -> None:
    s, path = scene
    result = occlux.reference(s, estimator=estimator, spp=6, seed=3, bounces=2, g=0.2)
    run_occlux(
        "reference",
        str(path),
        "--estimator",
        estimator,
        "--spp",
        "6",
        "--seed",
        "3",
        "--bounces",
        "2",
        "--g",
        "0.2",
        "-o",
        str(tmp_path),
        "--quiet",
    )
    cli = oiio_read(tmp_path / f"shells-{estimator}.exr")
    for c, name in enumerate("RGBA"):
        np.testing.assert_array_equal(result.mean[..., c], cli[f"beauty.{name}"])
    for c, name in enumerate("RGB"):
        np.testing.assert_array_equal(result.stderr[..., c], cli[f"stderr.{name}"])
    assert result.stderr.max() > 0.0 and not result.mean.flags.writeable


def test_reference_rejects_bad_parameters(scene) -> None:
    s, _ = scene
    with pytest.raises(occlux.OccluxError, match="estimator"):
        occlux.reference(s, estimator="path-traced")
    with pytest.raises(occlux.OccluxError, match="spp"):
        occlux.reference(s, spp=1)
    with pytest.raises(occlux.OccluxError, match="aperture"):
        occlux.reference(s, estimator="cone", aperture_deg=90.0)


def test_a_progress_callback_returning_false_cancels(scene) -> None:
    s, _ = scene
    calls: list[int] = []

    def stop(done: int, total: int) -> bool:
        calls.append(done)
        return False

    with pytest.raises(occlux.OccluxError, match="cancelled"):
        occlux.reference(s, spp=64, progress=stop)
    # Rows already running when the first one reports may finish, one per worker thread at
    # most (rayon's pool: RAYON_NUM_THREADS, else the CPUs this process may run on); no row
    # starts after, whatever the image's height.
    threads = int(os.environ.get("RAYON_NUM_THREADS") or len(os.sched_getaffinity(0)))
    assert 0 < len(calls) <= threads, f"{len(calls)} rows reported on {threads} threads"
