"""The Cycles cross-check (the mapping ``occlux.blender`` and the harness ``occlux_lab.cycles``).

First what the harness takes from the core: the scene as the core resolved it must be what the
scene file says (camera, lights, transfer function in raw units), from a file or from a Scene
object, and the core's writers must write what the harness gives them. Then the Blender side on
its own: a volume whose transmittance is known in closed form, through the mapped material and
camera. Then Occlux's Monte Carlo references against Cycles, estimator by estimator, on a phantom
and on a real CT (the engine): they must agree within noise, with Occlux in the same process (no
subprocess). Last, a deliberately wrong mapping (albedo 0.7 for 0.8, the camera turned by one
degree) must fail the same criteria, so that the agreement tests can fail; and ``occlux
check-cycles`` must hand every option to the harness.
"""

from __future__ import annotations

import json
import math
import os
import subprocess
import tomllib
from pathlib import Path

import numpy as np
import numpy.testing  # imported here: on first import it runs lscpu, which no_subprocess refuses
import occlux
import occlux.blender as ob
import pytest
from occlux_lab.cycles import main as harness_main
from occlux_lab.cycles.cli import parser as harness_parser
from occlux_lab.cycles.curve import render_curve
from occlux_testing import LAB, oiio_read, run_occlux

SPP = 128  # per pixel, for Occlux and for Cycles (32 renders of 4 samples)
SEEDS = 32
SHARED = Path(__file__).resolve().parents[3] / "shared" / "data" / "scivis"
EXAMPLES = Path(__file__).resolve().parents[2] / "examples"


@pytest.fixture(autouse=True)
def quiet_vulkan(monkeypatch):
    """wgpu's harmless warning about XDG_RUNTIME_DIR, silenced."""
    monkeypatch.setenv("XDG_RUNTIME_DIR", "/tmp")


@pytest.fixture
def no_subprocess(monkeypatch):
    """Any attempt to start a process fails the test: the harness runs Occlux in-process."""

    def refuse(*args, **kwargs):
        raise AssertionError(f"the harness started a process: {args!r}")

    monkeypatch.setattr(subprocess, "Popen", refuse)
    monkeypatch.setattr(subprocess, "run", refuse)
    monkeypatch.setattr(os, "system", refuse)
    monkeypatch.setattr(os, "posix_spawn", refuse)
    monkeypatch.setattr(os, "fork", refuse)


def write_nrrd(path: Path, values: np.ndarray) -> None:
    """A float NRRD with unit spacing; ``values`` has shape (nz, ny, nx)."""
    nz, ny, nx = values.shape
    header = (
        f"NRRD0004\ntype: float\ndimension: 3\nsizes: {nx} {ny} {nz}\nspacings: 1 1 1\n"
        "encoding: raw\nendian: little\n\n"
    )
    path.write_bytes(header.encode() + values.astype("<f4").tobytes())


# ---- The Blender side against a closed form ----

# A ramp along x, a slab along y, a band along z: value(i, j, k) = (1 + i) * G(j) * H(k) with G
# and H 1 inside and 0 on their first and last voxel. An absorber with sigma_t = K * value seen
# along +y by an orthographic camera against a background of 1: a pixel at (x, z) sees
# exp(-K * (1 + ix) * Htilde(kz) * sum(G)), with ix and kz its continuous voxel coordinates
# (trilinear: the integral over y of the hat functions of G is exactly sum(G)).
RAMP_DIMS = (16, 8, 8)  # nx, ny, nz
RAMP_K = 0.02
RAMP_SIZE = (64, 32)
RAMP_SCALE = 16.0  # the orthographic view spans the box's 16 units along x


def inner(n: int) -> np.ndarray:
    """1 on every voxel but the first and the last."""
    return np.r_[0.0, np.ones(n - 2), 0.0]


def ramp_values() -> np.ndarray:
    nx, ny, nz = RAMP_DIMS
    ramp = 1.0 + np.arange(nx)
    return inner(nz)[:, None, None] * inner(ny)[None, :, None] * ramp[None, None, :]


def ramp_transmittance(shift: float = 0.0) -> np.ndarray:
    """The closed form per pixel (row 0 at the top), voxel centres moved by ``shift`` voxels."""
    nx, ny, nz = RAMP_DIMS
    width, height = RAMP_SIZE
    half_x = RAMP_SCALE / 2
    half_z = half_x * height / width
    x = ((np.arange(width) + 0.5) / width * 2 - 1) * half_x
    z = (1 - (np.arange(height) + 0.5) / height * 2) * half_z
    # `centre = [0, 0, 0]`: the box is centred on the origin, voxel 0 half a voxel inside it.
    ix = x + nx / 2 - 0.5 + shift
    kz = z + nz / 2 - 0.5 + shift
    inside = np.abs(x) < nx / 2  # Occlux's medium ends at the faces of the box
    ramp = np.where(inside, 1.0 + np.clip(ix, 0, nx - 1), 0.0)
    band = np.interp(np.clip(kz, 0, nz - 1), np.arange(nz), inner(nz))
    return np.exp(-RAMP_K * (ny - 2) * band[:, None] * ramp[None, :])


@pytest.fixture(scope="module")
def ramp(tmp_path_factory) -> Path:
    folder = tmp_path_factory.mktemp("ramp")
    values = ramp_values()
    write_nrrd(folder / "ramp.nrrd", values)
    top = float(values.max())
    # Normalized units and a density scale of 2: sigma_t = K * value once both are applied.
    scene = folder / "ramp.toml"
    scene.write_text(
        f"""
background = 1.0
[volume]
path = "ramp.nrrd"
centre = [0, 0, 0]
[classification]
units = "normalized"
density_scale = 2.0
points = [
  {{ value = 0, sigma_t = 0, albedo = [0, 0, 0] }},
  {{ value = 1, sigma_t = {RAMP_K * top / 2}, albedo = [0, 0, 0] }},
]
[camera]
projection = "orthographic"
ortho_scale = {RAMP_SCALE}
position = [0, -10, 0]
target = [0, 0, 0]
width = {RAMP_SIZE[0]}
height = {RAMP_SIZE[1]}
[render]
method = "unshaded"
"""
    )
    run_occlux("export", str(scene), "-o", str(folder), "--quiet", "--device", "cpu")
    return scene


def test_cycles_transmittance_matches_the_closed_form(ramp):
    """Camera (orthographic, pixel centres), voxel centres, the box's faces, trilinear values,
    normalized units and the density scale, through Blender alone."""
    folder = ramp.parent
    scene = ob.build_scene(ramp, folder / "ramp.vdb", "ambient")
    _, header = ob.read_channels(folder / "ramp.exr")
    ob.check_camera(scene, json.loads(header["occlux/camera"]))
    cycles = ob.render_scene(scene, 512, SEEDS)
    got, se = cycles.mean[..., 0], cycles.stderr[..., 0]
    # Rays that miss the medium are exact (1 +- 0); the rest carry Cycles' noise.
    noisy = se > 0

    def z(shift: float) -> np.ndarray:
        return ((got - ramp_transmittance(shift)) / np.where(noisy, se, 1.0))[noisy]

    exact = z(0.0)
    assert noisy.sum() > 1000
    assert 0.75 < np.sqrt(np.mean(exact**2)) < 1.3, np.sqrt(np.mean(exact**2))
    assert abs(exact.mean()) < 0.25
    np.testing.assert_allclose(got[~noisy], 1.0, atol=1e-6)
    # Half a voxel off in the voxel-centre convention is plainly visible.
    for shift in (-0.5, 0.5):
        assert np.sqrt(np.mean(z(shift) ** 2)) > 5.0


# ---- Occlux against Cycles ----


def phantom_values(n: int = 40) -> np.ndarray:
    """A bone-like shell, a soft core and a dense rod, zero outside a sphere (so no border)."""
    c = (np.arange(n) - (n - 1) / 2) / ((n - 1) / 2)
    z, y, x = np.meshgrid(c, c, c, indexing="ij")
    r = np.sqrt(x**2 + y**2 + z**2)
    shell = np.exp(-(((r - 0.7) / 0.08) ** 2))
    core = np.exp(-((x - 0.15) ** 2 + (y + 0.1) ** 2 + (z - 0.1) ** 2) / 0.06)
    rod = np.exp(-((x + 0.2) ** 2 + (y - 0.25) ** 2) / 0.01) * (np.abs(z) < 0.6)
    return np.where(r > 0.9, 0.0, 1000 * shell + 400 * core + 1500 * rod)


@pytest.fixture(scope="module")
def phantom(tmp_path_factory) -> Path:
    """Four control points in raw units (kinks inside the ramp), coloured albedo, emission,
    density scale, a non-square image with a vertical field of view, a background unlike the
    ambient light, a sun and a point light."""
    folder = tmp_path_factory.mktemp("phantom")
    write_nrrd(folder / "phantom.nrrd", phantom_values())
    scene = folder / "phantom.toml"
    scene.write_text(
        """
background = 0.1
[volume]
path = "phantom.nrrd"
fit = 2.0
centre = [0, 0, 0]
[classification]
units = "raw"
density_scale = 1.5
points = [
  { value = 100, sigma_t = 0, albedo = [0.9, 0.6, 0.4] },
  { value = 300, sigma_t = 2, albedo = [0.9, 0.6, 0.4], emission = [0.3, 0.1, 0.0] },
  { value = 700, sigma_t = 6, albedo = [0.8, 0.8, 0.7] },
  { value = 1200, sigma_t = 20, albedo = [0.95, 0.95, 0.9] },
]
[camera]
position = [3.0, -3.5, 2.0]
target = [0, 0, 0]
fov_deg = 30
width = 72
height = 56
[[lights]]
type = "ambient"
radiance = 0.5
[[lights]]
type = "directional"
direction = [-0.3, -1.0, 1.2]
irradiance = 2.0
[[lights]]
type = "point"
position = [2.0, 1.0, 2.5]
intensity = [6.0, 5.0, 4.0]
[render]
method = "gradient"
"""
    )
    return scene


@pytest.fixture(scope="module")
def engine(tmp_path_factory) -> Path:
    """examples/engine.toml (the benchmark scene: lens and sensor, dense voxels on the box's
    bottom face) at 64 x 64."""
    nrrd = SHARED / "engine.nrrd"
    assert nrrd.is_file(), f"{nrrd} is missing: CI runs with ../shared beside the project"
    example = Path(__file__).resolve().parents[2] / "examples" / "engine.toml"
    text = example.read_text()
    text = text.replace('"../../shared/data/scivis/engine.nrrd"', json.dumps(str(nrrd)))
    text = text.replace("width = 256", "width = 64").replace("height = 256", "height = 64")
    scene = tmp_path_factory.mktemp("engine") / "engine.toml"
    scene.write_text(text)
    return scene


CASES = [
    ("phantom", "ambient", 0, 0.0),
    ("phantom", "single", 0, 0.4),
    ("phantom", "multiple", 4, -0.3),
    ("engine", "ambient", 0, 0.0),
    ("engine", "single", 0, 0.0),
    ("engine", "multiple", 8, 0.0),
]


@pytest.mark.parametrize(("volume", "estimator", "bounces", "g"), CASES)
def test_occlux_agrees_with_cycles(
    request, tmp_path, capsys, no_subprocess, volume, estimator, bounces, g
):
    scene = request.getfixturevalue(volume)
    argv = [str(scene), "--estimator", estimator, "--spp", str(SPP), "--seeds", str(SEEDS)]
    argv += ["--bounces", str(bounces), "--g", str(g), "--out", str(tmp_path)]
    status = harness_main(argv)
    printed = capsys.readouterr().out
    stem = f"{scene.stem}-{estimator}"
    report = json.loads((tmp_path / f"{stem}-report.json").read_text())
    assert status == 0, printed
    assert ob.Z_SCALE_RANGE[0] <= report["z_scale"] <= ob.Z_SCALE_RANGE[1], printed
    assert abs(report["mean_z"]) <= ob.MAX_ABS_MEAN_Z, printed
    assert report["fraction_over_3"] <= ob.MAX_FRACTION_OVER_3, printed
    assert report["pixels"] > 500 and report["agrees"]
    # What was written, read back: Cycles' mean and standard error, and the error map of z.
    occlux = ob.read_reference(tmp_path / f"{stem}.exr")
    cycles = oiio_read(tmp_path / f"{stem}-cycles.exr")
    mean = np.stack([cycles[f"beauty.{c}"] for c in "RGB"], axis=-1)
    stderr = np.stack([cycles[f"stderr.{c}"] for c in "RGB"], axis=-1)
    again = ob.compare(occlux, mean, stderr)
    assert again.z_scale == pytest.approx(report["z_scale"], rel=1e-4)
    zmap = oiio_read(tmp_path / f"{stem}-zmap.png")
    zmap = np.stack([zmap[c] for c in "RGB"], axis=-1)
    z = ob.z_scores(occlux, mean, stderr)
    np.testing.assert_allclose(zmap * 255, ob.error_map(occlux, z), atol=1.01)
    off = occlux.beauty[..., 3] <= ob.MASK_ALPHA
    np.testing.assert_allclose(zmap[off], 128 / 255, atol=1e-6)


# ---- A wrong mapping must fail ----


def ramp_node(scene):
    """The Color Ramp that gives the Principled Volume its colour (the albedo)."""
    volume = next(o for o in scene.objects if o.type == "VOLUME")
    tree = volume.data.materials[0].node_tree
    principled = next(n for n in tree.nodes if n.bl_idname == "ShaderNodeVolumePrincipled")
    return principled.inputs["Color"].links[0].from_node


def test_wrong_mappings_fail(engine, tmp_path):
    run_occlux("export", str(engine), "-o", str(tmp_path), "--quiet", "--device", "cpu")
    run_occlux(
        "reference", str(engine), "--estimator", "ambient", "--spp", str(SPP),
        "--seed", str(ob.OCCLUX_SEED), "-o", str(tmp_path), "--quiet",
    )  # fmt: skip
    occlux = ob.read_reference(tmp_path / "engine-ambient.exr")
    scene = ob.build_scene(engine, tmp_path / "engine.vdb", "ambient")

    # The camera turned by one degree about its up axis.
    from mathutils import Matrix

    camera = scene.camera
    true_pose = camera.matrix_world.copy()
    camera.matrix_world = true_pose @ Matrix.Rotation(math.radians(1.0), 4, "Y")
    with pytest.raises(ob.HarnessError, match="forward"):
        ob.check_camera(scene, occlux.camera)
    turned = ob.render_scene(scene, SPP, SEEDS)
    report = ob.compare(occlux, turned.mean, turned.stderr)
    assert not report.agrees(), report.table()
    assert report.rms_z > 2.0 and report.fraction_over_3 > 0.05, report.table()

    # Albedo 0.7 where the scene says 0.8.
    camera.matrix_world = true_pose
    ob.check_camera(scene, occlux.camera)
    for element in ramp_node(scene).color_ramp.elements:
        assert element.color[0] == pytest.approx(0.8)
        element.color = (0.7, 0.7, 0.7, element.color[3])
    darker = ob.render_scene(scene, SPP, SEEDS)
    report = ob.compare(occlux, darker.mean, darker.stderr)
    assert not report.agrees(), report.table()
    assert report.mean_z > 2 * ob.MAX_ABS_MEAN_Z, report.table()  # Occlux is brighter


# ---- Scenes the mapping refuses ----


def test_refuses_what_cycles_cannot_reproduce(phantom, ramp, tmp_path):
    text = phantom.read_text().replace(
        'path = "phantom.nrrd"', f"path = {json.dumps(str(phantom.with_suffix('.nrrd')))}"
    )
    start, end = text.index("points = ["), text.index("]\n[camera]") + 2
    many = ", ".join(f"{{ value = {v}, sigma_t = 1 }}" for v in range(ob.MAX_RAMP_STOPS + 1))
    cases = {
        "many": (f"points = [{many}]\n", "holds at most 32"),
        "2d": ('preset = "boundary-2d"\n', "2D transfer function"),  # with units normalized
    }
    for name, (classification, message) in cases.items():
        scene = tmp_path / f"{name}.toml"
        body = text[:start] + classification + text[end:]
        if classification.startswith("preset"):  # presets are placed on normalised values
            body = body.replace('units = "raw"', 'units = "normalized"')
        scene.write_text(body)
        with pytest.raises(ob.HarnessError, match=message):
            ob.load_scene(scene)
    # A preset is a 1D transfer function too, in normalized units placed on the tooth's
    # robust window (lo, hi inside the uint8 range): its points at lo + n (hi - lo).
    tooth = ob.load_scene(Path(__file__).resolve().parents[2] / "examples" / "tooth.toml")
    values = [p.value for p in tooth.points]
    lo, hi = values[0], values[-1]
    assert 0 <= lo < hi <= 255, values
    normalised = np.array([0, 0.12, 0.25, 0.45, 0.6, 1.0])
    assert values == pytest.approx(lo + normalised * (hi - lo), rel=1e-5)
    assert tooth.points[-1].sigma_t == pytest.approx(14.0)
    with pytest.raises(ob.HarnessError, match="Cycles can reproduce ambient, single, multiple"):
        ob.build_scene(phantom, ramp.parent / "ramp.vdb", "cone")
    # A VDB exported from another scene: its grid is not where this scene puts the volume.
    with pytest.raises(ob.HarnessError, match="export it again"):
        ob.build_scene(phantom, ramp.parent / "ramp.vdb", "ambient")


# ---- What the harness takes from the core ----


def unit(v) -> np.ndarray:
    a = np.asarray(v, dtype=np.float64)
    return a / np.linalg.norm(a)


def grey_or_rgb(value) -> tuple[float, float, float]:
    if isinstance(value, int | float):
        return (float(value),) * 3
    return tuple(float(c) for c in value)


def as_the_file_says(path: Path) -> dict:
    """The scene file read by hand with src/scene.rs's defaults and semantics (what the harness
    parsed itself before the core described scenes): the oracle of the tests below."""
    toml = tomllib.loads(path.read_text())
    cam = toml["camera"]
    position = np.asarray(cam["position"], dtype=np.float64)
    forward = unit(np.asarray(cam.get("target", [0, 0, 0]), dtype=np.float64) - position)
    right = unit(np.cross(forward, cam.get("up", [0, 0, 1])))
    width, height = cam.get("width", 512), cam.get("height", 512)
    perspective = cam.get("projection", "perspective") == "perspective"
    if "lens_mm" in cam:
        # Blender's sensor fit AUTO: the sensor spans the larger image side.
        tan_large = 0.5 * cam.get("sensor_mm", 36.0) / cam["lens_mm"]
        fov_y = 2.0 * math.atan(tan_large * min(1.0, height / width))
    else:
        fov_y = math.radians(cam.get("fov_deg", 40.0))
    ambient, lights = np.zeros(3), []
    for light in toml.get("lights", []):
        if light["type"] == "ambient":
            ambient += grey_or_rgb(light["radiance"])
        elif light["type"] == "directional":
            lights.append(("directional", unit(light["direction"]), light["irradiance"]))
        else:
            lights.append(("point", light["position"], light["intensity"]))
    tf = toml["classification"]
    vmin, vmax = occlux.Scene.load(path).load_volume().value_range
    scale = tf.get("density_scale", 1.0)
    points = sorted(
        (
            p["value"] if tf.get("units") == "raw" else vmin + p["value"] * (vmax - vmin),
            p["sigma_t"] * scale,
            grey_or_rgb(p.get("albedo", 1.0)),
            grey_or_rgb(p.get("emission", 0.0)),
        )
        for p in tf["points"]
    )
    return {
        "position": position,
        "forward": forward,
        "right": right,
        "up": np.cross(right, forward),
        "perspective": perspective,
        "fov_y": fov_y if perspective else None,
        "ortho_scale": None if perspective else cam.get("ortho_scale", 2.0),
        "size": (width, height),
        "ambient": ambient,
        "background": grey_or_rgb(toml.get("background", 0.0)),
        "lights": lights,
        "points": points,
    }


@pytest.mark.parametrize("volume", ["engine", "phantom", "ramp"])
def test_the_scene_from_the_core_is_the_scene_file(request, volume):
    """Camera frame, field of view (from a lens, from degrees) or orthographic scale, image
    size, lights and the transfer function in raw units, as the core resolved them."""
    path = request.getfixturevalue(volume)
    spec, want = ob.load_scene(path), as_the_file_says(path)
    cam = spec.camera
    for key in ("position", "forward", "right", "up"):
        np.testing.assert_allclose(getattr(cam, key), want[key], rtol=1e-6, atol=1e-6)
    assert cam.perspective == want["perspective"]
    for key in ("fov_y", "ortho_scale"):
        got = getattr(cam, key)
        assert got is None if want[key] is None else got == pytest.approx(want[key], rel=1e-6)
    assert (cam.width, cam.height) == want["size"]
    np.testing.assert_allclose(spec.ambient, want["ambient"], rtol=1e-6)
    np.testing.assert_allclose(spec.background, want["background"], rtol=1e-6)
    assert [light.kind for light in spec.lights] == [kind for kind, _, _ in want["lights"]]
    for light, (_, vector, rgb) in zip(spec.lights, want["lights"], strict=True):
        np.testing.assert_allclose(light.vector, vector, rtol=1e-6, atol=1e-7)
        np.testing.assert_allclose(light.rgb, grey_or_rgb(rgb), rtol=1e-6)
    assert len(spec.points) == len(want["points"])
    for point, (value, sigma_t, albedo, emission) in zip(spec.points, want["points"], strict=True):
        assert point.value == pytest.approx(value, rel=1e-6, abs=1e-6)
        assert point.sigma_t == pytest.approx(sigma_t, rel=1e-6)
        np.testing.assert_allclose(point.albedo, albedo, rtol=1e-6)
        np.testing.assert_allclose(point.emission, emission, rtol=1e-6)
    volume = occlux.Scene.load(path).load_volume()
    assert (spec.dims, spec.origin, spec.spacing) == (volume.dims, volume.origin, volume.spacing)
    assert spec.box == volume.bounds


def test_a_scene_object_builds_the_same_blender_scene(phantom, tmp_path, openvdb):
    """What the add-on does: a Scene from the scene's tree (no file) and the VDB of its volume;
    the harness maps it as it maps the file, and pads the sparse `value` grid on the scene's
    voxels."""
    scene = occlux.Scene.from_dict(tomllib.loads(phantom.read_text()), base_dir=phantom.parent)
    from_object, from_file = ob.load_scene(scene), ob.load_scene(phantom)
    assert from_object.path is None and from_file.path == phantom
    assert from_object == ob.SceneSpec(**{**vars(from_file), "path": None})
    volume = scene.load_volume()
    occlux.write_vdb(tmp_path / "phantom.vdb", {"value": volume})
    built = ob.build_scene(scene, tmp_path / "phantom.vdb", "multiple", bounces=2, g=0.3)
    ob.check_camera(built, scene.describe()["camera"])
    assert built.cycles.volume_bounces == 2
    assert sorted(o.data.type for o in built.objects if o.type == "LIGHT") == ["POINT", "SUN"]
    # Cycles renders the file as written: the scene's voxels plus one repeated on every side
    # (src/export/vdb.rs), placed one voxel out.
    (volume_object,) = (o for o in built.objects if o.type == "VOLUME")
    assert Path(volume_object.data.filepath) == (tmp_path / "phantom.vdb").resolve()
    grid = openvdb.read(str(tmp_path / "phantom.vdb"), "value")
    np.testing.assert_allclose(grid.transform.voxelSize(), volume.spacing, rtol=1e-6)
    corner = np.asarray(volume.origin) - np.asarray(volume.spacing)
    ijk = np.asarray(grid.transform.worldToIndex(tuple(corner)))
    np.testing.assert_allclose(ijk, np.round(ijk), atol=1e-4)
    nx, ny, nz = volume.dims
    dense = np.zeros((nx + 2, ny + 2, nz + 2), dtype=np.float32)
    grid.copyToArray(dense, ijk=tuple(int(i) for i in np.round(ijk)))
    want = np.pad(np.asarray(volume.values), 1, mode="edge").transpose(2, 1, 0)
    np.testing.assert_array_equal(dense, want)
    ob.remove_built()


def test_the_core_writes_what_the_harness_gives_it(tmp_path):
    """The error map's codes exactly, Cycles' float layers, the report's text, and a reference
    as `occlux reference` writes it, all through the core's atomic writers."""
    codes = np.arange(256, dtype=np.uint8).reshape(16, 16)
    rgb = np.stack([codes, codes[::-1], np.full_like(codes, 7)], axis=-1)
    occlux.write_png(tmp_path / "map.png", rgb)
    back = oiio_read(tmp_path / "map.png")
    got = np.stack([back[c] for c in "RGB"], axis=-1)
    np.testing.assert_array_equal(np.round(got * 255).astype(np.uint8), rgb)
    with pytest.raises(occlux.OccluxError, match="uint8"):
        occlux.write_png(tmp_path / "bad.png", rgb.astype(np.float32))

    rng = np.random.default_rng(3)
    mean, stderr = rng.random((5, 7, 3)), rng.random((5, 7, 3)) * 1e-3
    layers = {"beauty": mean, "stderr": stderr}
    occlux.write_exr_layers(tmp_path / "c.exr", layers, metadata={"occlux/note": "{}"})
    channels, attributes = ob.read_channels(tmp_path / "c.exr")
    for name, array in layers.items():
        for c, channel in enumerate("RGB"):
            want = array[..., c].astype(np.float32)
            np.testing.assert_array_equal(channels[f"{name}.{channel}"], want)
    assert attributes["occlux/note"] == "{}"
    mean[2, 3, 1] = np.nan
    with pytest.raises(occlux.OccluxError, match="non-finite"):
        occlux.write_exr_layers(tmp_path / "nan.exr", {"beauty": mean})
    assert not (tmp_path / "nan.exr").exists()
    occlux.write_text(tmp_path / "r.json", '{"a": 1}\n')
    assert json.loads((tmp_path / "r.json").read_text()) == {"a": 1}
    assert sorted(p.name for p in tmp_path.iterdir()) == ["c.exr", "map.png", "r.json"]

    scene = occlux.Scene.from_toml(
        '[volume]\nphantom = "sphere"\nsize = 8\n[camera]\nposition = [0, -4, 0]\n'
        'width = 6\nheight = 4\n[[lights]]\ntype = "ambient"\nradiance = 0.5\n'
    )
    result = occlux.reference(scene, estimator="ambient", spp=8, seed=ob.OCCLUX_SEED)
    written = occlux.write_reference(
        tmp_path, result, scene, stem="s-ambient", estimator="ambient", seed=ob.OCCLUX_SEED
    )
    assert [Path(p).name for p in written] == ["s-ambient.exr", "s-ambient.png"]
    image = ob.read_reference(tmp_path / "s-ambient.exr")
    np.testing.assert_array_equal(image.beauty, result.mean)
    np.testing.assert_array_equal(image.stderr, result.stderr)
    assert image.reference["estimator"] == "ambient" and image.reference["spp"] == 8
    assert image.camera == json.loads(json.dumps(scene.describe()["camera"]))


# ---- The command line ----


def test_check_cycles_hands_every_option_to_the_harness(tmp_path, monkeypatch):
    """`occlux check-cycles` runs `python -m occlux_lab.cycles`, with lab/python on PYTHONPATH
    (occlux_lab is not installed), with every option the harness takes (a stand-in Python
    records them), and its defaults are the harness's."""
    record = tmp_path / "argv"
    pythonpath = tmp_path / "pythonpath"
    python = tmp_path / "python"
    python.write_text(
        f'#!/bin/sh\n[ "$1" = -c ] && exit 0\nprintf "%s\\n" "$@" > "{record}"\n'
        f'printf "%s" "$PYTHONPATH" > "{pythonpath}"\n'
    )
    python.chmod(0o755)
    monkeypatch.setenv("OCCLUX_PYTHON", str(python))

    def harness_args(*args: str) -> dict:
        run_occlux("check-cycles", *args)
        argv = record.read_text().splitlines()
        assert argv[:2] == ["-m", "occlux_lab.cycles"], argv
        paths = [Path(p).resolve() for p in pythonpath.read_text().split(os.pathsep) if p]
        assert LAB.resolve() in paths, pythonpath.read_text()
        return vars(harness_parser().parse_args(argv[2:]))

    defaults = vars(harness_parser().parse_args(["scene.toml"]))
    assert harness_args("scene.toml") == defaults
    given = {
        "scene": Path("scene.toml"),
        "estimator": "multiple",
        "spp": 64,
        "seeds": 8,
        "bounces": 3,
        "g": -0.3,
        "out": tmp_path / "out",
    }
    assert given.keys() == defaults.keys()  # every option of the harness...
    assert all(given[k] != defaults[k] for k in given if k != "scene")  # ...off its default
    argv = ["scene.toml", "--estimator", "multiple", "--spp", "64", "--seeds", "8"]
    argv += ["--bounces", "3", "--g", "-0.3", "-o", str(tmp_path / "out")]
    assert harness_args(*argv) == given


# ---- Cycles' time-error curve and the speed-accuracy chart ----

TINY_SUN = """
background = 0.0
[volume]
phantom = "ct"
size = 24
[classification]
preset = "ct-bone"
[camera]
position = [2.4, -2.6, 1.4]
width = 24
height = 24
[[lights]]
type = "directional"
direction = [-0.3, -1.0, 1.2]
irradiance = 3.0
"""


def test_the_curve_renders_cycles_once_per_sample_count(tmp_path):
    """`python -m occlux_lab.cycles.curve`: one timed render per sample count, written as EXR and
    listed in the JSON; more samples, less noise against Occlux's reference."""
    scene = tmp_path / "tiny.toml"
    scene.write_text(TINY_SUN)
    out = tmp_path / "curve"
    report = render_curve(scene, "single", [1, 16], out)
    assert json.loads((out / "cycles-single-curve.json").read_text()) == report
    points = report["points"]
    assert [p["spp"] for p in points] == [1, 16]
    assert all(p["seconds"] > 0 for p in points)
    truth = occlux.reference(occlux.Scene.load(scene), "single", spp=512).mean[..., :3]
    lit = truth.max(axis=-1) > 1e-3
    errors = []
    for p in points:
        image = oiio_read(Path(p["exr"]))
        rgb = np.stack([image[c] for c in "RGB"], axis=-1)
        errors.append(np.sqrt(np.mean((rgb - truth)[lit] ** 2)) / np.mean(truth[lit]))
    # 16 times the samples: about a quarter of the error (bounded by the truth's own noise).
    assert errors[1] < 0.5 * errors[0], errors
    with pytest.raises(occlux.OccluxError, match="at least 1"):
        render_curve(scene, "single", [0], out)


def test_the_chart_runs_cycles_beside_the_methods(tmp_path, monkeypatch):
    """`occlux chart` with Cycles (CI's reduced set: one small scene, two sample counts): its
    curve in the JSON and the CSV, the speed-ups at equal error read off it, and the figure."""
    import sys

    monkeypatch.setenv("OCCLUX_PYTHON", sys.executable)
    scene = tmp_path / "tiny.toml"
    scene.write_text(TINY_SUN)
    out = tmp_path / "chart"
    run_occlux(
        "chart", "--scenes", str(scene), "--lightings", "sun", "--size", "24", "--spp", "256",
        "--mc-spp", "2,8", "--peers", "cycles", "--cycles-spp", "1,16", "--repeats", "1",
        "-o", str(out),
    )  # fmt: skip
    report = json.loads((out / "chart.json").read_text())
    (panel,) = report["panels"]
    cycles = panel["cycles"]
    assert [c["spp"] for c in cycles] == [1, 16]
    assert all(c["seconds"] > 0 for c in cycles)
    assert cycles[1]["rel_rmse"] < 0.5 * cycles[0]["rel_rmse"], cycles
    assert abs(cycles[1]["rel_bias"]) < 0.1, cycles  # Cycles agrees with Occlux's truth
    for point in panel["points"]:
        speedup = point["speedup_vs_cycles"]
        assert speedup is None or (math.isfinite(speedup) and speedup > 0), point
    assert any(p["speedup_vs_cycles"] is not None for p in panel["points"])
    csv = (out / "chart.csv").read_text().splitlines()
    assert sum(line.split(",")[2] == "cycles" for line in csv[1:]) == 2
    assert "Cycles" in (out / "chart.svg").read_text()


def test_the_harness_settles_a_framed_camera_as_occlux_renders_it():
    """A camera with no position frames the visible content once the volume is loaded; the
    harness (and so Cycles, the chart's Cycles curve and EEVEE) must take that camera, as
    ``occlux render`` and ``occlux.reference`` do, not the one framed on the bare box."""
    from occlux.blender.scene import load_scene

    framed = TINY_SUN.replace("position = [2.4, -2.6, 1.4]", "direction = [1, -1, 0.5]")
    scene = occlux.Scene.from_toml(framed)
    unsettled = occlux.Scene.from_toml(framed).describe()["camera"]["position"]
    spec = load_scene(scene)
    settled = occlux.Scene.from_toml(framed)
    settled.settle()
    want = settled.describe()["camera"]["position"]
    assert np.allclose(spec.camera.position, want, atol=1e-5), (spec.camera.position, want)
    assert not np.allclose(unsettled, want, atol=1e-3), "the framing did not depend on the data"
