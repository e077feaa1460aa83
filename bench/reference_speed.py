"""The Monte Carlo reference's time at equal error on the engine scenes (issue 16, item 8).

Runs `occlux reference` on the engine at 256 x 256 under a lighting of ../shared/bench/engine-cycles
(`--lighting`: sun, single scattering with shadows, the default; ambient, the uniform sky; multi,
the sun with 8 bounces) at several sample counts with this build and, side by side in the same run,
with a baseline build (`--baseline BIN`, e.g. one built from an earlier commit), interleaved so both
see the same machine load. Each point: wall time from scene file to image (median of `--repeats`),
and relative RMSE and bias over the volume's pixels (`occlux.image_error`,
docs/architecture.md#error-measure) against Cycles' 8192-spp reference. Then the speed-up at equal
error: the baseline's time at its largest sample count over the time this build needs to reach the
same error (interpolated between measured counts in log-log).

    .venv/bin/python bench/reference_speed.py --baseline ../old/target/release/occlux
"""

from __future__ import annotations

import argparse
import itertools
import math
import re
import statistics
import subprocess
import tempfile
import time
from pathlib import Path

import numpy as np
import occlux
from occlux.blender import read_channels

ROOT = Path(__file__).resolve().parents[1]
BENCH = ROOT.parent / "shared" / "bench" / "engine-cycles"
# lighting: (scene, estimator, Cycles reference, its background radiance)
LIGHTINGS = {
    "sun": ("engine-sun.toml", "single", "sun_ref8192.exr", 0.0),
    "ambient": ("engine-ao.toml", "ambient", "ambient_ref8192.exr", 1.0),
    "multi": ("engine-multi.toml", "multiple", "multi_ref8192.exr", 0.0),
}


def rgb(path: Path, layer: str = "") -> np.ndarray:
    channels, _ = read_channels(path)
    prefix = f"{layer}." if layer else ""
    return np.stack([channels[prefix + c] for c in "RGB"], axis=-1)


def scene_file(name: str, background: float, folder: Path) -> Path:
    """The example scene with the Cycles reference's background and an absolute volume path."""
    text = (ROOT / "examples" / name).read_text()
    text = re.sub(r"(?m)^background = .*$", f"background = {background}", text)
    volume = (ROOT / "examples" / "../../shared/data/scivis/engine.nrrd").resolve()
    text = text.replace('"../../shared/data/scivis/engine.nrrd"', f'"{volume}"')
    path = folder / name
    path.write_text(text)
    return path


def run(binary: Path, scene: Path, estimator: str, spp: int, out: Path) -> tuple[float, np.ndarray]:
    """One reference render: its wall time and its mean image."""
    argv = [str(binary), "reference", str(scene), "--estimator", estimator]
    argv += ["--spp", str(spp), "--quiet", "-o", str(out)]
    start = time.perf_counter()
    subprocess.run(argv, check=True)
    seconds = time.perf_counter() - start
    return seconds, rgb(out / f"{scene.stem}-{estimator}.exr", "beauty")


def time_at_error(points: list[tuple[int, float, float]], error: float) -> float:
    """The time a build needs for `error`, interpolated in log-log between its (spp, time,
    error) points; NaN outside their range."""
    points = sorted(points)
    for (_, t0, e0), (_, t1, e1) in itertools.pairwise(points):
        if e1 <= error <= e0:
            f = math.log(e0 / error) / math.log(e0 / e1)
            return math.exp(math.log(t0) + f * math.log(t1 / t0))
    return math.nan


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--binary", type=Path, default=ROOT / "target/release/occlux")
    parser.add_argument("--baseline", type=Path, help="an earlier build's occlux binary")
    parser.add_argument("--lighting", choices=sorted(LIGHTINGS), default="sun")
    parser.add_argument("--spp", default="8,16,32,64", help="sample counts, comma-separated")
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()
    counts = [int(s) for s in args.spp.split(",")]
    builds = {"this build": args.binary}
    if args.baseline:
        builds["baseline"] = args.baseline
    scene_name, estimator, truth_file, background = LIGHTINGS[args.lighting]
    truth = rgb(BENCH / truth_file)
    results: dict[str, list[tuple[int, float, float]]] = {name: [] for name in builds}
    with tempfile.TemporaryDirectory() as tmp:
        scene = scene_file(scene_name, background, Path(tmp))
        print(f"{'build':<12} {'spp':>5} {'time s':>8} {'rel RMSE':>9} {'bias':>8}")
        for spp in counts:
            times: dict[str, list[float]] = {name: [] for name in builds}
            images = {}
            for _ in range(args.repeats):
                for name, binary in builds.items():
                    seconds, images[name] = run(binary, scene, estimator, spp, Path(tmp) / name)
                    times[name].append(seconds)
            for name in builds:
                error = occlux.image_error(images[name], truth, background)
                median = statistics.median(times[name])
                results[name].append((spp, median, error["rel_rmse"]))
                print(
                    f"{name:<12} {spp:>5} {median:>8.2f} {error['rel_rmse']:>9.4f} "
                    f"{100 * error['bias']:>+7.1f}%"
                )
    if "baseline" in results:
        spp, seconds, error = max(results["baseline"])
        needed = time_at_error(results["this build"], error)
        print(
            f"equal error {error:.4f} (baseline at {spp} spp, {seconds:.2f} s): this build "
            f"{needed:.2f} s, {seconds / needed:.2f}x faster"
        )


if __name__ == "__main__":
    main()
