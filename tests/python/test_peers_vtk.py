"""VTK's GPU ray caster as a peer of ``occlux chart`` (occlux_lab.peers.vtk): the mapping onto
Occlux's optical model checked against Occlux itself, and the command line's contract.

VTK renders offscreen through EGL on Mesa's software OpenGL (llvmpipe). A 32^3 CT phantom,
48^2 pixels: the whole file takes a few seconds."""

from __future__ import annotations

import csv
import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import occlux
import pytest
from occlux_lab.peers import vtk as peer
from occlux_testing import REPO, lab_env, oiio_read, run_occlux

BACKGROUND = 0.05
AMBIENT = '[[lights]]\ntype = "ambient"\nradiance = [0.5, 0.6, 0.7]'
SUN = '[[lights]]\ntype = "directional"\ndirection = [-0.3, -1.0, 1.2]\nirradiance = 3.0'


def scene_toml(
    lights: str,
    volume: str = 'phantom = "ct"\nsize = 32',
    classification: str = 'preset = "ct-soft-tissue"\ndensity_scale = 0.35',
    background: float = BACKGROUND,
) -> str:
    """The demo's view of a small phantom, rendered by Occlux's unshaded ray caster at a fine
    step (its own step error far below the bounds here)."""
    return f"""background = {background}
[volume]
{volume}
[classification]
{classification}
[camera]
position = [3.2, -3.2, 2.6]
target = [0, 0, 0]
fov_deg = 36
width = 48
height = 40
{lights}
[render]
method = "unshaded"
step = 0.01
"""


def silhouette(rgb: np.ndarray) -> np.ndarray:
    return np.abs(rgb[..., :3].mean(-1) - BACKGROUND) > 0.005 * BACKGROUND


def test_ambient_matches_occlux_unshaded() -> None:
    """Under ambient light VTK has no occlusion, so it renders Occlux's ``unshaded`` method
    (ambient x albedo emission-absorption): this pins the placement of the voxels, the camera
    (a non-square image), the transfer function, the units and the background. VTK's error is
    its step's: at 1 voxel the trilinear field between samples is missed by up to a few
    percent where the extinction changes fast, and it falls about as the step squared."""
    scene = occlux.Scene.from_toml(scene_toml(AMBIENT))
    truth = occlux.render(scene, device="cpu").beauty
    renderer = peer.VtkRenderer(peer.load_scene(scene, "ambient"), "ambient")
    errors = []
    for step in (1.0, 0.25):
        image = renderer.render(peer.Setting("test", step))
        assert image.shape == (40, 48, 3)
        mask, reference_mask = silhouette(image), silhouette(truth)
        iou = (mask & reference_mask).sum() / (mask | reference_mask).sum()
        assert iou > 0.99, f"silhouettes differ (IoU {iou:.4f}): placement or camera"
        errors.append(occlux.image_error(image, truth, BACKGROUND)["rel_rmse"])
    assert errors[0] < 0.03, errors
    assert errors[1] < 0.005, errors
    assert errors[1] < errors[0] / 4, f"no convergence with the step: {errors}"


def test_sun_with_shadows_matches_the_reference_and_shadows_matter() -> None:
    """Under a sun, VTK's volumetric scattering with shadows (reach 1) against Occlux's Monte
    Carlo single-scattering reference (noise ~0.5 % at 4096 spp): the 1 / (4 pi) of the light's
    intensity and the shadows' optical depth. VTK's shadow rays take a first step of a full
    sample distance and each step's opacity at its start, so the error is first order in the
    step (measured 0.12 / 0.085 / 0.054 at 1 / 0.5 / 0.25 voxel). Without shadows it is many
    times worse: the phantom shadows itself."""
    scene = occlux.Scene.from_toml(scene_toml(SUN))
    truth = occlux.reference(scene, estimator="single", spp=4096)
    renderer = peer.VtkRenderer(peer.load_scene(scene, "single"), "single")

    def error(setting: peer.Setting) -> dict[str, float]:
        image = renderer.render(setting)
        return occlux.image_error(image, truth.mean, BACKGROUND, truth.stderr)

    coarse = error(peer.Setting("test", 1.0, True))
    fine = error(peer.Setting("test", 0.25, True))
    unshadowed = error(peer.Setting("test", 0.25, False))
    assert fine["noise"] < 0.01
    assert fine["rel_rmse"] < 0.08, fine
    assert abs(fine["bias"]) < 0.02, fine
    assert fine["rel_rmse"] < coarse["rel_rmse"], (fine, coarse)
    assert unshadowed["rel_rmse"] > 4 * fine["rel_rmse"], (unshadowed, fine)


def test_a_box_that_is_not_a_cube_is_padded_to_one(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """VTK marches shadow rays in texture coordinates: a 2:2:1 box is padded with void cells to
    a cube, whose shadows match the reference (measured 0.04, +0.7 % at 96 x 80); without the
    padding they are too dark (0.09, -7.5 %: the shadow steps' world length depends on the
    direction)."""
    values = np.zeros((16, 32, 32), dtype=np.float32)
    values[3:13, 6:26, 6:26] = 1.0
    values[5:11, 12:20, 4:28] = 2.0
    path = tmp_path / "slab.npy"
    np.save(path, values)
    volume = f'path = "{path}"\nfit = 2.0'
    classification = (
        'units = "raw"\npoints = [{ value = 0, sigma_t = 0, albedo = [0.9, 0.9, 0.9] }, '
        "{ value = 2, sigma_t = 4, albedo = [0.9, 0.7, 0.5] }]"
    )
    scene = occlux.Scene.from_toml(scene_toml(SUN, volume, classification))
    truth = occlux.reference(scene, estimator="single", spp=4096)
    mapped = peer.load_scene(scene, "single")
    setting = peer.Setting("test", 0.25, True)
    renderer = peer.VtkRenderer(mapped, "single")
    assert renderer.padding == (0, 0, 16)
    lo, hi = renderer.box()
    assert np.allclose(hi - lo, hi[0] - lo[0])
    padded = occlux.image_error(renderer.render(setting), truth.mean, BACKGROUND, truth.stderr)
    monkeypatch.setattr(peer, "cube_padding", lambda dims, spacing: (0, 0, 0))
    unpadded_renderer = peer.VtkRenderer(mapped, "single")
    unpadded = occlux.image_error(
        unpadded_renderer.render(setting), truth.mean, BACKGROUND, truth.stderr
    )
    assert padded["rel_rmse"] < 0.07, padded
    assert abs(padded["bias"]) < 0.03, padded
    assert unpadded["bias"] < padded["bias"] - 0.03, (unpadded, padded)
    assert padded["rel_rmse"] < unpadded["rel_rmse"], (padded, unpadded)


def test_bright_lights_are_not_clipped() -> None:
    """VTK clamps each sample's colour to [0, 1] and its window is 8-bit: with the light scale
    and the float framebuffer a sun 100 times brighter gives an image 100 times brighter."""
    dim = occlux.Scene.from_toml(scene_toml(SUN.replace("3.0", "0.03"), background=0.0))
    bright = occlux.Scene.from_toml(scene_toml(SUN.replace("3.0", "300.0"), background=0.0))
    setting = peer.Setting("test", 1.0, True)
    images = []
    for scene in (dim, bright):
        mapped = peer.load_scene(scene, "single")
        images.append(peer.VtkRenderer(mapped, "single").render(setting))
    assert images[1].max() > 10.0  # far above 1: an 8-bit or clamped path would show it
    np.testing.assert_allclose(images[1], 1e4 * images[0], rtol=1e-3, atol=1e-4)


def run_cli(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "occlux_lab.peers.vtk", *args],
        capture_output=True,
        text=True,
        cwd=REPO,
        env=lab_env(),
    )


def test_cli_writes_the_curve(tmp_path: Path) -> None:
    scene = tmp_path / "sun.toml"
    scene.write_text(scene_toml(SUN))
    out = tmp_path / "out"
    result = run_cli(str(scene), "--estimator", "single", "--out", str(out))
    assert result.returncode == 0, result.stderr
    report = json.loads((out / "vtk-single-curve.json").read_text())
    assert report["peer"] == "vtk" and report["estimator"] == "single"
    assert report["version"].startswith("9.")
    assert "median" in report["timing"]
    settings = [p["setting"] for p in report["points"]]
    assert len(settings) == 4 and len(set(settings)) == 4
    assert "shadows off" in settings[-1]
    for point in report["points"]:
        assert point["seconds"] > 0.0
        channels = oiio_read(Path(point["exr"]))
        rgb = np.stack([channels[f"beauty.{c}"] for c in "RGB"], axis=-1)
        assert rgb.shape == (40, 48, 3)
        assert np.isfinite(rgb).all() and rgb.max() > BACKGROUND


def test_cli_refuses_what_vtk_cannot_render(tmp_path: Path) -> None:
    """Emission has no VTK counterpart beside the lights: exit code 2 and a message naming it;
    so has the sun lighting of a scene without a sun."""
    emitting = (
        'units = "raw"\npoints = [{ value = 0, sigma_t = 0, albedo = [1, 1, 1] }, '
        "{ value = 1, sigma_t = 5, albedo = [1, 1, 1], emission = [2, 0, 0] }]"
    )
    scene = tmp_path / "emits.toml"
    scene.write_text(scene_toml(AMBIENT, classification=emitting))
    result = run_cli(str(scene), "--estimator", "ambient", "--out", str(tmp_path / "a"))
    assert result.returncode == 2
    assert result.stderr.startswith("error: ") and "emits light" in result.stderr
    unlit = tmp_path / "unlit.toml"
    unlit.write_text(scene_toml(AMBIENT))
    result = run_cli(str(unlit), "--estimator", "single", "--out", str(tmp_path / "b"))
    assert result.returncode == 2
    assert "needs a sun or a lamp" in result.stderr


def test_the_chart_runs_vtk_beside_the_methods(tmp_path: Path, monkeypatch) -> None:
    """`occlux chart --peers vtk`: VTK's settings as a series of the panel, each measured
    against the chart's truth (finer steps closer to it, shadows off far from it), with its
    speed-up left out (no Cycles curve here), in the CSV and the figure."""
    monkeypatch.setenv("OCCLUX_PYTHON", sys.executable)
    scene = tmp_path / "sun.toml"
    scene.write_text(scene_toml(SUN))
    out = tmp_path / "chart"
    run_occlux(
        "chart", "--scenes", str(scene), "--lightings", "sun", "--size", "32", "--spp", "1024",
        "--mc-spp", "2,8", "--peers", "vtk", "--repeats", "1", "-o", str(out),
    )  # fmt: skip
    (panel,) = json.loads((out / "chart.json").read_text())["panels"]
    assert panel["cycles"] == []
    # The sample distances with shadows are VTK's axis; the point without shadows is apart.
    axis, off_axis = panel["peers"]
    assert axis["peer"] == "VTK" and "render" in axis["timing"]
    assert off_axis["peer"] == "VTK, no shadows"
    on = [p["rel_rmse"] for p in axis["points"]]
    (off,) = [p["rel_rmse"] for p in off_axis["points"]]
    assert len(on) >= 2 and all(np.isfinite(on)), on
    assert on[-1] < on[0] and off > 2 * on[-1], (on, off)
    for p in axis["points"] + off_axis["points"]:
        assert p["speedup_vs_cycles"] is None and p["speedup_vs_monte_carlo"] > 0, p
    with open(out / "chart.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    assert sum(row["method"].startswith("vtk") for row in rows) == len(on) + 1
    svg = (out / "chart.svg").read_text()
    assert "VTK" in svg and "VTK, no shadows" in svg
