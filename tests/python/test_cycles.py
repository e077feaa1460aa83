"""The Cycles cross-check (``occlux.cycles``).

First the Blender side on its own: a volume whose transmittance is known in closed form, through
the mapped material and camera. Then Occlux's Monte Carlo references against Cycles, estimator by
estimator, on a phantom and on a real CT (the engine): they must agree within noise. Last, a
deliberately wrong mapping (albedo 0.7 for 0.8, the camera turned by one degree) must fail the
same criteria, so that the agreement tests can fail.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import occlux.cycles as oc
import pytest
from occlux_testing import occlux_binary, oiio_read, run_occlux

SPP = 128  # per pixel, for Occlux and for Cycles (32 renders of 4 samples)
SEEDS = 32
SHARED = Path(__file__).resolve().parents[3] / "shared" / "data" / "scivis"


@pytest.fixture(autouse=True)
def harness_binary(monkeypatch):
    """The harness runs the CLI that the other tests run."""
    monkeypatch.setenv("OCCLUX_BIN", str(occlux_binary()))
    monkeypatch.setenv("XDG_RUNTIME_DIR", "/tmp")


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
    scene = oc.build_scene(ramp, folder / "ramp.vdb", "ambient")
    _, header = oc.read_channels(folder / "ramp.exr")
    oc.check_camera(scene, json.loads(header["occlux/camera"]))
    cycles = oc.render_scene(scene, 512, SEEDS)
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
def test_occlux_agrees_with_cycles(request, tmp_path, capsys, volume, estimator, bounces, g):
    scene = request.getfixturevalue(volume)
    argv = [str(scene), "--estimator", estimator, "--spp", str(SPP), "--seeds", str(SEEDS)]
    argv += ["--bounces", str(bounces), "--g", str(g), "--out", str(tmp_path)]
    status = oc.main(argv)
    printed = capsys.readouterr().out
    stem = f"{scene.stem}-{estimator}"
    report = json.loads((tmp_path / f"{stem}-report.json").read_text())
    assert status == 0, printed
    assert oc.RMS_Z_RANGE[0] <= report["rms_z"] <= oc.RMS_Z_RANGE[1], printed
    assert abs(report["mean_z"]) <= oc.MAX_ABS_MEAN_Z, printed
    assert report["fraction_over_3"] <= oc.MAX_FRACTION_OVER_3, printed
    assert report["pixels"] > 500 and report["agrees"]
    # What was written, read back: Cycles' mean and standard error, and the error map of z.
    occlux = oc.read_reference(tmp_path / f"{stem}.exr")
    cycles = oiio_read(tmp_path / f"{stem}-cycles.exr")
    mean = np.stack([cycles[f"beauty.{c}"] for c in "RGB"], axis=-1)
    stderr = np.stack([cycles[f"stderr.{c}"] for c in "RGB"], axis=-1)
    again = oc.compare(occlux, mean, stderr)
    assert again.rms_z == pytest.approx(report["rms_z"], rel=1e-4)
    zmap = oiio_read(tmp_path / f"{stem}-zmap.png")
    zmap = np.stack([zmap[c] for c in "RGB"], axis=-1)
    z = oc.z_scores(occlux, mean, stderr, report["noise_floor"])
    np.testing.assert_allclose(zmap * 255, oc.error_map(occlux, z), atol=1.01)
    off = occlux.beauty[..., 3] <= oc.MASK_ALPHA
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
        "--seed", str(oc.OCCLUX_SEED), "-o", str(tmp_path), "--quiet",
    )  # fmt: skip
    occlux = oc.read_reference(tmp_path / "engine-ambient.exr")
    scene = oc.build_scene(engine, tmp_path / "engine.vdb", "ambient")

    # The camera turned by one degree about its up axis.
    from mathutils import Matrix

    camera = scene.camera
    true_pose = camera.matrix_world.copy()
    camera.matrix_world = true_pose @ Matrix.Rotation(math.radians(1.0), 4, "Y")
    with pytest.raises(oc.HarnessError, match="forward"):
        oc.check_camera(scene, occlux.camera)
    turned = oc.render_scene(scene, SPP, SEEDS)
    report = oc.compare(occlux, turned.mean, turned.stderr)
    assert not report.agrees(), report.table()
    assert report.rms_z > 2.0 and report.fraction_over_3 > 0.05, report.table()

    # Albedo 0.7 where the scene says 0.8.
    camera.matrix_world = true_pose
    oc.check_camera(scene, occlux.camera)
    for element in ramp_node(scene).color_ramp.elements:
        assert element.color[0] == pytest.approx(0.8)
        element.color = (0.7, 0.7, 0.7, element.color[3])
    darker = oc.render_scene(scene, SPP, SEEDS)
    report = oc.compare(occlux, darker.mean, darker.stderr)
    assert not report.agrees(), report.table()
    assert report.mean_z > 2 * oc.MAX_ABS_MEAN_Z, report.table()  # Occlux is brighter


# ---- Scenes the mapping refuses ----


def test_refuses_what_cycles_cannot_reproduce(phantom, ramp, tmp_path):
    text = phantom.read_text().replace(
        'path = "phantom.nrrd"', f"path = {json.dumps(str(phantom.with_suffix('.nrrd')))}"
    )
    start, end = text.index("points = ["), text.index("]\n[camera]") + 2
    many = ", ".join(f"{{ value = {v}, sigma_t = 1 }}" for v in range(oc.MAX_RAMP_STOPS + 1))
    cases = {
        "many": (f"points = [{many}]\n", "holds at most 32"),
        "2d": ('preset = "boundary-2d"\n', "2D transfer function"),
    }
    for name, (classification, message) in cases.items():
        scene = tmp_path / f"{name}.toml"
        scene.write_text(text[:start] + classification + text[end:])
        with pytest.raises(oc.HarnessError, match=message):
            oc.load_scene(scene)
    # A preset is a 1D transfer function too, in normalized units.
    tooth = oc.load_scene(Path(__file__).resolve().parents[2] / "examples" / "tooth.toml")
    assert [p.value for p in tooth.points] == pytest.approx([0, 30.6, 63.75, 114.75, 153, 255])
    assert tooth.points[-1].sigma_t == pytest.approx(14.0)
    with pytest.raises(oc.HarnessError, match="Cycles can reproduce ambient, single, multiple"):
        oc.build_scene(phantom, ramp.parent / "ramp.vdb", "cone")
    # A VDB exported from another scene: its grid is not where this scene puts the volume.
    with pytest.raises(oc.HarnessError, match="export it again"):
        oc.build_scene(phantom, ramp.parent / "ramp.vdb", "ambient")
