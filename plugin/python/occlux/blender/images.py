"""Images in and out: reading renders and ``occlux reference`` EXRs (through OpenImageIO, which
Blender bundles), and writing the check's outputs with the core's atomic writers (EXR layers, PNG,
JSON)."""

from __future__ import annotations

import json
import os
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from occlux._occlux import write_exr_layers, write_png, write_text

from .bundled import bundled_module
from .common import HarnessError

if TYPE_CHECKING:
    from .blender import CyclesImage
    from .stats import Report


def read_channels(path: str | os.PathLike[str]) -> tuple[dict[str, np.ndarray], dict[str, str]]:
    """Every channel of an image file (float32, row 0 at the top) and its string attributes."""
    oiio = bundled_module("OpenImageIO")
    image = oiio.ImageInput.open(str(path))
    if not image:
        raise HarnessError(f"{path}: cannot read it: {oiio.geterror()}")
    try:
        spec = image.spec()
        pixels = image.read_image(format="float")
        attributes = {a.name: a.value for a in spec.extra_attribs if isinstance(a.value, str)}
        names = list(spec.channelnames)
    finally:
        image.close()
    if pixels is None:
        raise HarnessError(f"{path}: cannot read its pixels: {oiio.geterror()}")
    return {name: pixels[..., c] for c, name in enumerate(names)}, attributes


@dataclass
class OccluxImage:
    """An ``occlux reference`` image: mean RGBA and standard error RGB, (height, width, c), and
    its header's ``occlux/reference`` and ``occlux/camera`` descriptions."""

    beauty: np.ndarray
    stderr: np.ndarray
    reference: dict[str, Any]
    camera: dict[str, Any]


def read_reference(path: str | os.PathLike[str]) -> OccluxImage:
    """Reads the EXR that ``occlux reference`` writes (layers ``beauty`` and ``stderr``)."""
    channels, attributes = read_channels(path)
    try:
        beauty = np.stack([channels[f"beauty.{c}"] for c in "RGBA"], axis=-1)
        stderr = np.stack([channels[f"stderr.{c}"] for c in "RGB"], axis=-1)
        reference = json.loads(attributes["occlux/reference"])
        camera = json.loads(attributes["occlux/camera"])
    except KeyError as e:
        raise HarnessError(f"{path}: not an `occlux reference` image (no {e})") from e
    return OccluxImage(beauty.astype(np.float64), stderr.astype(np.float64), reference, camera)


def write_outputs(
    out: Path, stem: str, occlux: OccluxImage, cycles: CyclesImage, report: Report, extra: dict
) -> list[Path]:
    """OUT/STEM-cycles.exr (Cycles' mean and standard error: float32 layers ``beauty`` and
    ``stderr``, R, G, B), OUT/STEM-zmap.png (the error map) and OUT/STEM-report.json (the report
    and ``extra``), each written atomically by the core."""
    from .stats import MAX_ABS_MEAN_Z, MAX_FRACTION_OVER_3, Z_SCALE_RANGE, error_map, z_scores

    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    exr = out / f"{stem}-cycles.exr"
    write_exr_layers(exr, {"beauty": cycles.mean, "stderr": cycles.stderr}, float32=True)
    png = out / f"{stem}-zmap.png"
    z = z_scores(occlux, cycles.mean, cycles.stderr)
    write_png(png, error_map(occlux, z, report.mask_alpha))
    summary = {
        **extra,
        **asdict(report),
        "agrees": report.agrees(),
        "criteria": {
            "z_scale": list(Z_SCALE_RANGE),
            "max_abs_mean_z": MAX_ABS_MEAN_Z,
            "max_fraction_over_3": MAX_FRACTION_OVER_3,
        },
        "cycles_seeds": cycles.seeds,
        "cycles_spp_per_seed": cycles.spp_per_seed,
    }
    js = out / f"{stem}-report.json"
    write_text(js, json.dumps(summary, indent=2) + "\n")
    return [exr, png, js]
