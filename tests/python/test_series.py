"""Time series on Dask (occlux.series) against the command line (occlux series): the same files
(bytes; EXRs by pixels and attributes) from a LocalCluster of two worker processes as from a
serial run, a killed worker's frame redone, the stage's time samples read by usd-core, and an
unreachable scheduler refused with nothing written."""

from __future__ import annotations

import os
import sys
from pathlib import Path

import cloudpickle
import distributed
import numpy as np
import occlux
import occlux.usd
import pytest
from occlux.blender import bundled_module
from occlux_testing import run_occlux

FRAMES = 12
SIDE = 20

SCENE = """
[volume]
frames = "step_*.nrrd"
fit = "auto"
[classification]
preset = "simulation"
[camera]
width = 24
height = 24
[[lights]]
type = "directional"
direction = [-0.3, -1.0, 1.2]
irradiance = 4.0
[render]
method = "ipsvi"
"""


def ball(t: int) -> np.ndarray:
    """Frame t of a moving, brightening ball (z, y, x order: NRRD's x runs fastest)."""
    z, y, x = np.mgrid[0:SIDE, 0:SIDE, 0:SIDE].astype(np.float32)
    d = np.sqrt((x - 6 - 0.7 * t) ** 2 + (y - 10) ** 2 + (z - 10) ** 2)
    return (np.clip(5 - d, 0, None) * 40 * (1 + 0.1 * t)).astype("<f4")


def make_series(folder: Path) -> Path:
    """A 12-frame series of NRRD files and its scene; returns the scene file."""
    folder.mkdir(parents=True, exist_ok=True)
    for t in range(FRAMES):
        header = (
            f"NRRD0004\ntype: float\ndimension: 3\nsizes: {SIDE} {SIDE} {SIDE}\n"
            "encoding: raw\nendian: little\nspacings: 1 1 1\n\n"
        )
        (folder / f"step_{t + 1:02}.nrrd").write_bytes(header.encode() + ball(t).tobytes())
    scene = folder / "ball.toml"
    scene.write_text(SCENE)
    return scene


def contents(folder: Path) -> dict[str, object]:
    """Every file's bytes by name; for an EXR its channels and header attributes, as the exr
    crate writes header attributes in hash-map order, which differs between processes."""
    return {
        p.name: exr_content(p) if p.suffix == ".exr" else p.read_bytes()
        for p in sorted(folder.iterdir())
    }


def exr_content(path: Path) -> tuple:
    oiio = bundled_module("OpenImageIO")
    image = oiio.ImageInput.open(str(path))
    assert image, oiio.geterror()
    try:
        spec = image.spec()
        attributes = sorted((a.name, str(a.value)) for a in spec.extra_attribs)
        pixels = image.read_image(format="float")
    finally:
        image.close()
    return list(spec.channelnames), attributes, pixels.tobytes()


@pytest.fixture(scope="module")
def serial(tmp_path_factory, oiio) -> tuple[Path, Path]:
    """The series' scene, and the folder the command line writes it into frame after frame
    (renders, and VDBs with an AO grid)."""
    root = tmp_path_factory.mktemp("series")
    scene = make_series(root / "data")
    out = root / "serial"
    run_occlux("series", str(scene), "--device", "cpu", "--ao", "cdf", "-o", str(out), "--quiet")
    return scene, out


@pytest.fixture(scope="module")
def cluster():
    """A LocalCluster of two worker processes, one thread each."""
    with (
        distributed.LocalCluster(
            n_workers=2, threads_per_worker=1, processes=True, dashboard_address=":0"
        ) as local,
        distributed.Client(local) as client,
    ):
        yield client


def test_dask_writes_the_files_of_a_serial_run(serial, cluster, tmp_path: Path) -> None:
    scene, out = serial
    expected = contents(out)
    assert len(expected) == 3 * FRAMES + 2  # vdb, exr, png per frame; stage; manifest
    seen: list[tuple[int, int]] = []
    done = occlux.series(
        scene,
        None,
        tmp_path / "dask",
        ao="cdf",
        client=cluster,
        progress=lambda d, n: seen.append((d, n)),
    )
    assert sorted(done.written) == list(range(1, FRAMES + 1)) and done.complete == []
    assert seen[-1] == (FRAMES, FRAMES)
    assert done.stage == tmp_path / "dask" / "ball.usda"
    assert contents(tmp_path / "dask") == expected
    # A rerun resumes: every frame is complete, nothing is rewritten.
    again = occlux.series(scene, None, tmp_path / "dask", ao="cdf", client=cluster)
    assert again.written == {} and again.complete == list(range(1, FRAMES + 1))
    assert contents(tmp_path / "dask") == expected


class KillFirstExecution(distributed.WorkerPlugin):
    """Kills its worker's process the first time any worker starts a task (a marker file makes
    it once across processes): the frame in flight dies with it, mid-way."""

    def __init__(self, marker: str) -> None:
        self.marker = marker

    def transition(self, key, start: str, finish: str, **kwargs) -> None:
        if finish != "executing":
            return
        try:
            os.close(os.open(self.marker, os.O_CREAT | os.O_EXCL))
        except FileExistsError:
            return
        os._exit(1)


def test_a_killed_workers_frame_is_redone(serial, tmp_path: Path) -> None:
    scene, serial_out = serial
    expected = contents(serial_out)
    marker = tmp_path / "killed"
    cloudpickle.register_pickle_by_value(sys.modules[__name__])
    with (
        distributed.LocalCluster(
            n_workers=2, threads_per_worker=1, processes=True, dashboard_address=":0"
        ) as local,
        distributed.Client(local) as client,
    ):
        client.register_plugin(KillFirstExecution(str(marker)))
        done = occlux.series(scene, None, tmp_path / "out", ao="cdf", client=client)
    assert marker.exists(), "a worker must have been killed"
    assert sorted(done.written) == list(range(1, FRAMES + 1))
    assert contents(tmp_path / "out") == expected


def test_the_stage_plays_the_frames_in_usd_core(serial) -> None:
    from pxr import Usd, UsdVol

    _, out = serial
    stage = Usd.Stage.Open(str(out / "ball.usda"))
    assert (stage.GetStartTimeCode(), stage.GetEndTimeCode()) == (1, FRAMES)
    volume = UsdVol.Volume(stage.GetPrimAtPath("/World/Volume"))
    grids = ("density", "value", "ao")
    assert {str(p) for p in volume.GetFieldPaths().values()} == {
        f"/World/Volume/{g}" for g in grids
    }
    for grid in grids:
        field = UsdVol.OpenVDBAsset(stage.GetPrimAtPath(f"/World/Volume/{grid}"))
        path = field.GetFilePathAttr()
        assert path.GetTimeSamples() == list(range(1, FRAMES + 1))
        for frame in (1, 5, FRAMES):
            asset = path.Get(Usd.TimeCode(frame))
            assert asset.path == f"./ball_{frame:04}.vdb"
            assert Path(asset.resolvedPath) == out / f"ball_{frame:04}.vdb"


def test_pxr_authors_the_series_time_samples_as_the_core_writes_them(serial, tmp_path) -> None:
    from pxr import Usd

    scene_path, out = serial
    scene = occlux.Scene.load(scene_path)
    files = [f"ball_{f:04}.vdb" for f in range(1, FRAMES + 1)]
    grids = ["density", "value", "ao"]
    description = occlux.stage_description(scene, scene.load_volume(), files[0], grids, files)
    occlux.usd.write_stage(tmp_path / "pxr.usda", description)
    core = Usd.Stage.Open(str(out / "ball.usda"))
    ours = Usd.Stage.Open(str(tmp_path / "pxr.usda"))
    for stage in (core, ours):
        assert (stage.GetStartTimeCode(), stage.GetEndTimeCode()) == (1, FRAMES)
        assert stage.GetTimeCodesPerSecond() == 24
    for grid in grids:
        a, b = (s.GetAttributeAtPath(f"/World/Volume/{grid}.filePath") for s in (core, ours))
        assert a.GetTimeSamples() == b.GetTimeSamples() == list(range(1, FRAMES + 1))
        for frame in a.GetTimeSamples():
            assert a.Get(frame).path == b.Get(frame).path == f"./{files[int(frame) - 1]}"


def test_export_alone_writes_no_renders(serial, tmp_path: Path) -> None:
    scene, serial_out = serial
    out = tmp_path / "export"
    run_occlux("series", str(scene), "--device", "cpu", "--export", "--ao", "cdf", "-o", str(out))
    written = contents(out)
    assert not [n for n in written if n.endswith((".exr", ".png"))]
    # The grids do not depend on whether the renders were written.
    for name in (f"ball_{f:04}.vdb" for f in range(1, FRAMES + 1)):
        assert written[name] == (serial_out / name).read_bytes()


def test_an_unreachable_scheduler_is_named_and_nothing_is_written(serial, tmp_path: Path) -> None:
    scene, _ = serial
    out = tmp_path / "never"
    with pytest.raises(occlux.SeriesError, match="cannot reach the Dask scheduler at tcp://"):
        occlux.series(scene, None, out, client="tcp://127.0.0.1:9")
    assert not out.exists()


def test_bad_frames_are_refused_before_any_work(cluster, tmp_path: Path) -> None:
    scene = make_series(tmp_path / "data")
    (tmp_path / "data" / "step_04.nrrd").unlink()
    with pytest.raises(occlux.OccluxError, match=r"misses step_04\.nrrd"):
        occlux.series(scene, None, tmp_path / "out", client=cluster)
    assert not (tmp_path / "out").exists()
