"""Statistics of the comparison: per-pixel z scores in units of the combined standard error,
the agreement criteria, the report and the error map."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from .common import HarnessError

if TYPE_CHECKING:
    from .images import OccluxImage

MASK_ALPHA = 0.01
"""Pixels whose Occlux alpha (fraction of camera paths that interact) exceeds this are compared."""

Z_CLIP = 4.0
"""The error map's colour scale spans z in [-Z_CLIP, Z_CLIP]."""

# Agreement: z scores of unbiased estimates of the same image are ~N(0, 1).
Z_SCALE_RANGE = (0.8, 1.25)
"""The scale of z (see Report.z_scale) must lie in this range: the standard errors are honest."""
MAX_ABS_MEAN_Z = 0.2
MAX_FRACTION_OVER_3 = 0.01
"""At most this fraction of z beyond 3 (0.27 % for a normal variable): few outliers."""

MAD_OF_NORMAL = 0.6744897501960817
"""The median of |z| for z ~ N(0, 1)."""


@dataclass
class Report:
    """How an Occlux image and a Cycles image differ over the mask (Occlux alpha > mask_alpha).

    z = (occlux - cycles) / sqrt(se_occlux^2 + se_cycles^2) per pixel and channel;
    ``z_scale`` is median(|z|) / MAD_OF_NORMAL, the spread of z that its bulk shows (1 when the
    standard errors are honest), which a few outlying pixels cannot move as they move ``rms_z``:
    those are counted by ``fraction_over_3``. (In the engine's deepest shadow, at 1e-8 of the
    image's brightness, Cycles reads about 4e-7 where two independent Occlux estimators, residual
    ratio tracking and unbiased ray marching, agree on 10-30 times less: a handful of |z| of
    10-20 that set RMS z to 1.4 alone.) ``rmse`` is the radiance RMSE and ``rms_noise`` the RMS
    of the combined standard error, over the mask."""

    pixels: int
    mask_alpha: float
    mean_z: float
    z_scale: float
    rms_z: float
    fraction_over_3: float
    max_abs_z: float
    rmse: float
    rms_noise: float
    rmse_over_noise: float
    mean_occlux: float
    mean_cycles: float

    def agrees(self) -> bool:
        """Whether the images agree within noise: the scale of z in Z_SCALE_RANGE, |mean z| at
        most MAX_ABS_MEAN_Z, and at most MAX_FRACTION_OVER_3 of the z scores beyond 3."""
        return (
            Z_SCALE_RANGE[0] <= self.z_scale <= Z_SCALE_RANGE[1]
            and abs(self.mean_z) <= MAX_ABS_MEAN_Z
            and self.fraction_over_3 <= MAX_FRACTION_OVER_3
        )

    def table(self) -> str:
        rows = [
            ("pixels compared", f"{self.pixels} (Occlux alpha > {self.mask_alpha})"),
            ("mean radiance", f"Occlux {self.mean_occlux:.5g}, Cycles {self.mean_cycles:.5g}"),
            ("mean z", f"{self.mean_z:+.3f}"),
            ("scale of z", f"{self.z_scale:.3f} (median |z| / {MAD_OF_NORMAL:.4f})"),
            ("RMS z", f"{self.rms_z:.3f}"),
            ("|z| > 3", f"{100 * self.fraction_over_3:.2f} %"),
            ("max |z|", f"{self.max_abs_z:.2f}"),
            ("RMSE", f"{self.rmse:.4g} ({self.rmse_over_noise:.3f} x the RMS noise)"),
            ("verdict", "agree within noise" if self.agrees() else "DISAGREE"),
        ]
        return "\n".join(f"{k:<16} {v}" for k, v in rows)


def z_scores(
    occlux: OccluxImage,
    cycles_mean: np.ndarray,
    cycles_stderr: np.ndarray,
) -> np.ndarray:
    """Per-pixel, per-channel z = (occlux - cycles) / sqrt(se_o^2 + se_c^2); 0 where the
    denominator and the difference are both zero, NaN where only the denominator is."""
    diff = occlux.beauty[..., :3] - cycles_mean
    sigma = np.sqrt(occlux.stderr**2 + cycles_stderr**2)
    with np.errstate(divide="ignore", invalid="ignore"):
        z = diff / sigma
    z[(sigma == 0.0) & (diff == 0.0)] = 0.0
    z[(sigma == 0.0) & (diff != 0.0)] = np.nan
    return z


def _mask(occlux: OccluxImage, mask_alpha: float) -> np.ndarray:
    mask = occlux.beauty[..., 3] > mask_alpha
    if not mask.any():
        raise HarnessError(f"no pixel has Occlux alpha > {mask_alpha}: the volume is not in view")
    return mask


def compare(
    occlux: OccluxImage,
    cycles_mean: np.ndarray,
    cycles_stderr: np.ndarray,
    mask_alpha: float = MASK_ALPHA,
) -> Report:
    """Compares an Occlux reference with a Cycles estimate of the same image over the pixels
    the volume covers (Occlux alpha > ``mask_alpha``)."""
    if cycles_mean.shape != (*occlux.beauty.shape[:2], 3):
        raise HarnessError(
            f"image sizes differ: Occlux {occlux.beauty.shape[:2]}, Cycles {cycles_mean.shape[:2]}"
        )
    mask = _mask(occlux, mask_alpha)
    z = z_scores(occlux, cycles_mean, cycles_stderr)[mask]
    if np.isnan(z).any():
        bad = int(np.isnan(z).any(axis=-1).sum())
        raise HarnessError(f"{bad} pixels differ although both have zero standard error")
    diff = (occlux.beauty[..., :3] - cycles_mean)[mask]
    noise = (occlux.stderr**2 + cycles_stderr**2)[mask]
    rmse = float(np.sqrt(np.mean(diff**2)))
    rms_noise = float(np.sqrt(np.mean(noise)))
    return Report(
        pixels=int(mask.sum()),
        mask_alpha=mask_alpha,
        mean_z=float(z.mean()),
        z_scale=float(np.median(np.abs(z)) / MAD_OF_NORMAL),
        rms_z=float(np.sqrt(np.mean(z**2))),
        fraction_over_3=float(np.mean(np.abs(z) > 3.0)),
        max_abs_z=float(np.abs(z).max()),
        rmse=rmse,
        rms_noise=rms_noise,
        rmse_over_noise=rmse / rms_noise if rms_noise > 0.0 else math.inf,
        mean_occlux=float(occlux.beauty[..., :3][mask].mean()),
        mean_cycles=float(cycles_mean[mask].mean()),
    )


def error_map(occlux: OccluxImage, z: np.ndarray, mask_alpha: float = MASK_ALPHA) -> np.ndarray:
    """An 8-bit RGB picture of the mean z over the channels, clipped to [-Z_CLIP, Z_CLIP]: blue
    where Occlux is darker than Cycles, red where brighter, white where they agree; pixels
    outside the mask are grey."""
    t = np.clip(np.nan_to_num(z.mean(axis=-1)) / Z_CLIP, -1.0, 1.0)[..., None]
    white = np.array([1.0, 1.0, 1.0])
    blue = np.array([0.23, 0.30, 0.75])
    red = np.array([0.71, 0.02, 0.15])
    rgb = np.where(t < 0.0, white + (blue - white) * -t, white + (red - white) * t)
    rgb[occlux.beauty[..., 3] <= mask_alpha] = 0.5
    return np.round(rgb * 255.0).astype(np.uint8)
