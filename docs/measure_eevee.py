"""EEVEE (``occlux_lab.peers.eevee``) on the engine under the chart's three lightings: its error
against Occlux's Monte Carlo truth at each setting of its quality ladder, and its time, in one
process (one shader compile). The figures of docs/peers-eevee.md.

    PYTHONPATH=plugin/python XDG_RUNTIME_DIR=/tmp .venv/bin/python docs/measure_eevee.py \\
        --size 128 --spp 1024 --out out/eevee-engine

The harness ``occlux_lab`` is not installed: this script puts lab/python on sys.path itself.

Each lighting's scene is written as ``occlux chart`` writes it (lab/src/chart/measure.rs
``LightingMode::scene_tree``): the camera at SIZE^2, the volume path absolute, the lights of the
lighting (the engine's sun for sun and multi, uniform ambient radiance 1 for ambient).
"""

from __future__ import annotations

import argparse
import json
import sys
import time
import tomllib
from pathlib import Path

import numpy as np
import occlux
from occlux.blender.images import read_channels

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO / "lab" / "python"))  # occlux_lab, the harness (not installed)

from occlux_lab.peers.eevee import render_curve  # noqa: E402

LIGHTINGS = {"ambient": "ambient", "sun": "single", "multi": "multiple"}


def toml_value(value) -> str:
    if isinstance(value, str):
        return json.dumps(value)
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, list):
        return "[" + ", ".join(toml_value(v) for v in value) + "]"
    if isinstance(value, dict):
        return "{ " + ", ".join(f"{k} = {toml_value(v)}" for k, v in value.items()) + " }"
    return repr(value)


def scene_text(tree: dict) -> str:
    """A TOML of ``tree`` (tables of scalars, lists and inline tables; lights as an array)."""
    lines = []
    for key, value in tree.items():
        if not isinstance(value, dict | list) or (isinstance(value, list) and key != "lights"):
            lines.append(f"{key} = {toml_value(value)}")
    for key, value in tree.items():
        if isinstance(value, dict):
            lines.append(f"[{key}]")
            lines += [f"{k} = {toml_value(v)}" for k, v in value.items()]
    for light in tree.get("lights", []):
        lines.append("[[lights]]")
        lines += [f"{k} = {toml_value(v)}" for k, v in light.items()]
    return "\n".join(lines) + "\n"


def chart_scene(source: Path, lighting: str, size: int) -> dict:
    """The scene tree ``occlux chart`` renders for ``lighting``."""
    tree = tomllib.loads(source.read_text())
    tree.pop("render", None)
    tree["camera"]["width"] = tree["camera"]["height"] = size
    path = tree["volume"].get("path")
    if path is not None:
        tree["volume"]["path"] = str((source.parent / path).resolve())
    wanted = ("ambient",) if lighting == "ambient" else ("directional", "point")
    lights = [light for light in tree.get("lights", []) if light["type"] in wanted]
    if not lights and lighting == "ambient":
        lights = [{"type": "ambient", "radiance": 1.0}]
    tree["lights"] = lights
    return tree


def main() -> None:
    p = argparse.ArgumentParser()
    p.add_argument("--scene", type=Path, default=REPO / "examples" / "engine-sun.toml")
    p.add_argument("--size", type=int, default=128)
    p.add_argument("--spp", type=int, default=1024)
    p.add_argument("--lightings", default="sun,multi,ambient")
    p.add_argument("--out", type=Path, default=Path("out/eevee-engine"))
    args = p.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)
    rows = []
    for lighting in args.lightings.split(","):
        estimator = LIGHTINGS[lighting]
        scene_path = args.out / f"{args.scene.stem}-{lighting}.toml"
        scene_path.write_text(scene_text(chart_scene(args.scene, lighting, args.size)))
        core = occlux.Scene.load(scene_path)
        started = time.perf_counter()
        truth = occlux.reference(core, estimator, spp=args.spp, seed=7)
        reference_s = time.perf_counter() - started
        mean = np.asarray(truth.mean)[..., :3]
        stderr = np.asarray(truth.stderr)[..., :3]
        background = float(np.mean(core.describe()["lighting"]["background"]))
        report = render_curve(scene_path, estimator, args.out / lighting)
        for point in report["points"]:
            channels, _ = read_channels(point["exr"])
            image = np.stack([channels[c] for c in "RGB"], axis=-1).astype(np.float64)
            error = occlux.image_error(image, mean, background, stderr)
            rows.append(
                {
                    "lighting": lighting,
                    "setting": point["setting"],
                    "seconds": point["seconds"],
                    "rel_rmse": error["rel_rmse"],
                    "bias": error["bias"],
                    "truth_noise": error["noise"],
                }
            )
            print(
                f"{lighting:8s} {point['setting']:60s} {point['seconds']:7.2f} s  "
                f"rel RMSE {error['rel_rmse']:.3f}  bias {100 * error['bias']:+.1f} %  "
                f"(truth noise {error['noise']:.3f})",
                flush=True,
            )
        print(
            f"{lighting}: warm-up {report['warmup_seconds']:.1f} s, renders per setting "
            f"{report['renders_per_setting']}, reference {reference_s:.1f} s",
            flush=True,
        )
    (args.out / "eevee-engine.json").write_text(json.dumps(rows, indent=2))


if __name__ == "__main__":
    main()
