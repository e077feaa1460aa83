"""An ambient visibility on every shared volume with the same settings (issues 14 and 37).

Writes one measurement scene per volume of ../shared/data/scivis (its README's table gives the
kind: the `ct-bone` preset for CT and unknown scans, `simulation` for simulations; the box fitted
to 2 units, the camera of examples/bonsai.toml) into a temporary folder, and runs `occlux
sweep-accuracy` on all of them: AO-shaded DVR with the sweep's visibility under uniform ambient
light of radiance 1 seen against a background of 1 (the engine scene of
../shared/bench/engine-cycles), against Occlux's ambient Monte Carlo reference. No parameter is
set per volume.

    .venv/bin/python bench/sweep_shared.py --method ordinates --size 128 --spp 1024 \
        --out ordinates-shared.json
"""

from __future__ import annotations

import argparse
import re
import subprocess
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SCIVIS = ROOT.parent / "shared" / "data" / "scivis"
PRESETS = {"ct": "ct-bone", "unknown": "ct-bone", "simulation": "simulation"}

SCENE = """\
background = 1.0

[volume]
path = "{path}"
fit = 2.0
centre = [0, 0, 0]

[classification]
preset = "{preset}"

[camera]
position = [3.2, -3.2, 2.6]
target = [0, 0, 0]
fov_deg = 36
width = 128
height = 128

[[lights]]
type = "ambient"
radiance = 1.0
"""


def volumes() -> list[tuple[str, str]]:
    """(file name, kind) of each row of the shared README's table."""
    table = (SCIVIS / "README.md").read_text()
    rows = re.findall(r"^\| (\w+\.nrrd) \| [^|]+ \| (\w+) \|", table, re.M)
    if not rows:
        raise SystemExit(f"no volumes listed in {SCIVIS / 'README.md'}")
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--occlux", default=str(ROOT / "target" / "release" / "occlux"))
    parser.add_argument("--method", default="ordinates", help="ordinates or sweep-physical")
    parser.add_argument("--size", type=int, default=128)
    parser.add_argument("--spp", type=int, default=1024)
    parser.add_argument("--out", default="sweep-shared.json")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as folder:
        scenes = []
        for name, kind in volumes():
            scene = Path(folder) / f"{Path(name).stem}.toml"
            scene.write_text(SCENE.format(path=SCIVIS / name, preset=PRESETS[kind]))
            scenes.append(str(scene))
        subprocess.run(
            [args.occlux, "sweep-accuracy", "--method", args.method, "--scenes", ",".join(scenes),
             "--size", str(args.size), "--spp", str(args.spp), "--device", "cpu", "-o", args.out],
            check=True,
        )  # fmt: skip


if __name__ == "__main__":
    main()
