"""USD stages authored with usd-core's ``pxr`` API from the core's stage description.

The core works out the conventions once (camera apertures from the field of view, light frames,
units; see ``occlux::export::usd``); this module turns that description into prims, either in a
new ``.usda``/``.usdc`` file or inside a stage of your own pipeline::

    import json, occlux, occlux.usd
    from pxr import Usd

    description = json.loads(occlux.stage_description(scene, volume, "engine.vdb", ["density"]))
    occlux.usd.write_stage("engine.usda", description)  # a stage of its own, or:
    occlux.usd.add_to_stage(Usd.Stage.Open("shot.usda"), description)  # into an existing one

The stage is laid out for importers that make an object of every imageable prim (Blender's):
the field prims are ``invisible`` and ``/Render`` is typeless, so only ``/World`` is an empty.
Blender's import reads no ``RenderSettings``; the add-on's Import Occlux Stage applies them.
"""

from __future__ import annotations

import json
import os
from pathlib import Path
from types import SimpleNamespace
from typing import Any

from occlux._occlux import OccluxError

Description = dict[str, Any]


def _pxr() -> SimpleNamespace:
    """usd-core's modules, imported on first use (usd-core is an optional dependency)."""
    try:
        from pxr import Gf, Sdf, Usd, UsdGeom, UsdLux, UsdRender, UsdVol
    except ImportError as e:
        raise OccluxError("USD authoring needs usd-core: pip install 'occlux[usd]'") from e
    return SimpleNamespace(
        Gf=Gf, Sdf=Sdf, Usd=Usd, UsdGeom=UsdGeom, UsdLux=UsdLux, UsdRender=UsdRender, UsdVol=UsdVol
    )


def _load(description: Description | str) -> Description:
    return json.loads(description) if isinstance(description, str) else description


def _set_transform(px: SimpleNamespace, prim, rows: list[list[float]]) -> None:
    """One matrix op; the rows are USD's (row vectors, translation in the last row)."""
    xform = px.UsdGeom.Xformable(prim)
    xform.ClearXformOpOrder()
    xform.AddTransformOp().Set(px.Gf.Matrix4d(rows))


def add_to_stage(stage, description: Description | str) -> None:
    """Authors the described volume, camera, lights and render settings into ``stage``, and sets
    its up axis, metres per unit and (if unset) default prim."""
    px = _pxr()
    gf, usd_geom, usd_lux, usd_vol = px.Gf, px.UsdGeom, px.UsdLux, px.UsdVol
    d = _load(description)
    usd_geom.SetStageUpAxis(stage, getattr(usd_geom.Tokens, d["up_axis"].lower()))
    usd_geom.SetStageMetersPerUnit(stage, d["meters_per_unit"])
    if d.get("time_codes"):
        start, end = d["time_codes"]
        stage.SetStartTimeCode(start)
        stage.SetEndTimeCode(end)
        stage.SetTimeCodesPerSecond(24)
        stage.SetFramesPerSecond(24)
    root = usd_geom.Xform.Define(stage, f"/{d['root']}")
    if not stage.HasDefaultPrim():
        stage.SetDefaultPrim(root.GetPrim())

    v = d["volume"]
    volume = usd_vol.Volume.Define(stage, f"/{d['root']}/{v['name']}")
    volume.CreateExtentAttr([gf.Vec3f(*v["extent"][0]), gf.Vec3f(*v["extent"][1])])
    for f in v["fields"]:
        path = volume.GetPath().AppendChild(f["name"])
        asset = usd_vol.OpenVDBAsset.Define(stage, path)
        file_path = asset.CreateFilePathAttr(px.Sdf.AssetPath(f["file_path"]))
        # A series' stage: the file at each time code (the default above for readers of one).
        for code, file in f.get("time_samples", []):
            file_path.Set(px.Sdf.AssetPath(file), code)
        asset.CreateFieldNameAttr(f["field_name"])
        asset.CreateFieldClassAttr("fogVolume")
        asset.CreateFieldDataTypeAttr("float")
        # Read through the Volume's relationship, never drawn itself: invisible, so importers
        # (Blender's) make no object of it.
        asset.CreateVisibilityAttr(usd_geom.Tokens.invisible)
        volume.CreateFieldRelationship(f["name"], path)

    c = d["camera"]
    camera = usd_geom.Camera.Define(stage, f"/{d['root']}/{c['name']}")
    camera.CreateProjectionAttr(c["projection"])
    camera.CreateFocalLengthAttr(c["focal_length"])
    camera.CreateHorizontalApertureAttr(c["horizontal_aperture"])
    camera.CreateVerticalApertureAttr(c["vertical_aperture"])
    camera.CreateClippingRangeAttr(gf.Vec2f(*c["clipping_range"]))
    _set_transform(px, camera.GetPrim(), c["transform"])

    kinds = {
        "DistantLight": usd_lux.DistantLight,
        "SphereLight": usd_lux.SphereLight,
        "DomeLight": usd_lux.DomeLight,
    }
    for light in d["lights"]:
        schema = kinds[light["kind"]].Define(stage, f"/{d['root']}/{light['name']}")
        schema.CreateColorAttr(gf.Vec3f(*light["color"]))
        schema.CreateIntensityAttr(light["intensity"])
        if light["kind"] == "DistantLight":
            schema.CreateAngleAttr(0.0)
        elif light["kind"] == "SphereLight":
            schema.CreateRadiusAttr(0.0)
            schema.CreateTreatAsPointAttr(True)
        _set_transform(px, schema.GetPrim(), light["transform"])

    # Typeless, not a Scope: an imageable prim would become an empty in Blender.
    stage.DefinePrim("/Render")
    settings = px.UsdRender.Settings.Define(stage, "/Render/Settings")
    settings.CreateResolutionAttr(gf.Vec2i(*d["resolution"]))
    settings.CreateCameraRel().SetTargets([camera.GetPath()])
    stage.SetMetadata("renderSettingsPrimPath", "/Render/Settings")


def write_stage(path: str | os.PathLike[str], description: Description | str) -> None:
    """Writes the described stage to ``path`` (.usda or .usdc) atomically: a temporary file
    beside it, renamed over it when complete."""
    usd = _pxr().Usd
    path = Path(path)
    if not path.parent.is_dir():
        raise OccluxError(f"{path}: folder {path.parent} does not exist")
    temp = path.with_name(f".occlux-{os.getpid()}-{path.name}")
    try:
        stage = usd.Stage.CreateNew(str(temp))
        add_to_stage(stage, description)
        stage.GetRootLayer().Save()
        del stage
        os.replace(temp, path)
    finally:
        temp.unlink(missing_ok=True)
