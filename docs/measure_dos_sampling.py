"""DOS with area and solid-angle sampling on the shared engine ambient scene
(../shared/bench/engine-cycles: uniform sky of radiance 1, 256 x 256), in one run: render time
(median of 3 after a warm-up, CPU) and relative RMSE / bias over the volume's pixels
(`occlux.image_error`, docs/architecture.md#error-measure) against Cycles' 8192-spp reference and
against Occlux's ambient Monte Carlo reference (256 spp).

    .venv/bin/python docs/measure_dos_sampling.py
"""

import statistics
import time
from pathlib import Path

import numpy as np
import occlux
from occlux.blender import read_channels

SHARED = Path(__file__).resolve().parents[2] / "shared"
ENGINE = str(SHARED / "data/scivis/engine.nrrd")
tree = {
    "background": 1.0,
    "volume": {"path": ENGINE, "fit": 2.0, "centre": [0, 0, 0]},
    "classification": {
        "units": "raw",
        "points": [
            {"value": 60, "sigma_t": 0, "albedo": [0.8] * 3},
            {"value": 120, "sigma_t": 20, "albedo": [0.8] * 3},
        ],
    },
    "camera": {
        "position": [3.2, -3.2, 2.6],
        "target": [0, 0, 0],
        "lens_mm": 65,
        "sensor_mm": 36,
        "width": 256,
        "height": 256,
    },
    "lights": [{"type": "ambient", "radiance": 1.0}],
    "render": {"method": "gradient"},
}
ch, _ = read_channels(SHARED / "bench/engine-cycles/ambient_ref8192.exr")
cycles = np.stack([ch["R"], ch["G"], ch["B"]], axis=-1)
base = occlux.Scene.from_dict(tree)
t0 = time.perf_counter()
ref = occlux.reference(base, estimator="ambient", spp=256)
print(f"Occlux ambient reference 256 spp: {time.perf_counter() - t0:.1f} s")
mc = np.asarray(ref.mean)[..., :3]
e = occlux.image_error(mc, cycles, 1.0)
print(f"Occlux MC reference vs Cycles: rel RMSE {e['rel_rmse']:.3f} bias {e['bias']:+.3f}")
for theta in (30, 50, 80, 89):
    for sampling in ("area", "solid-angle"):
        t = dict(tree, render={"method": "dos", "theta_deg": theta, "sampling": sampling})
        scene = occlux.Scene.from_dict(t)
        occlux.render(scene, device="cpu")  # warm-up
        times = []
        for _ in range(3):
            t0 = time.perf_counter()
            img = occlux.render(scene, device="cpu")
            times.append(time.perf_counter() - t0)
        beauty = np.asarray(img.beauty)[..., :3]
        ec = occlux.image_error(beauty, cycles, 1.0)
        em = occlux.image_error(beauty, mc, 1.0, np.asarray(ref.stderr))
        print(
            f"theta {theta:>2} {sampling:<11} {statistics.median(times):.3f} s  vs Cycles "
            f"{ec['rel_rmse']:.3f} ({ec['bias']:+.1%})  vs Occlux MC {em['rel_rmse']:.3f} "
            f"({em['bias']:+.1%}, noise {em['noise']:.3f})"
        )
