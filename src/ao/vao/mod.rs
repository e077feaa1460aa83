//! Volumetric ambient occlusion (Ruiz, Szirmay-Kalos, Umenhoffer, Boada, Feixas, Sbert 2010).
//!
//! The openness O(x) of a voxel is the fraction of its neighbourhood that holds less matter
//! than x itself: the CDF F of the field over the tangent sphere of radius R around x,
//! evaluated at the field's value v(x). A point on a flat interface gets 1/2, a point in a
//! hollow more, a point in a crevice less; so does empty space (every neighbour ties). This
//! module computes F; the `ao` grid is written as min(1, 2F) unless asked for raw F
//! ([`crate::ao::AoConvention`]). The paper's speed comes from not counting: it
//! reconstructs F from a few local statistics over the sphere's bounding box (side 2R + 1),
//! computed by separable filters.
//!
//! - [`stats`]: the statistics (minimum, maximum, mean, second moment) at a cost per voxel that
//!   does not depend on R: running sums for the moments, van Herk/Gil-Werman for the extremes.
//! - [`estimate`]: F(v) from the statistics: (a) the CDF reconstruction t^beta, (b) the
//!   Gaussian CDF (Winitzki's erf, or the exact erf), (c) Penner and Mitchell's Chebyshev bound.
//! - [`exact`]: (d) F counted voxel by voxel over the ball, the reference the others are
//!   measured against (cost O(R^3) per voxel).
//! - [`cpu`] and [`gpu`]: the twins that compute a whole AO volume; they agree to float
//!   rounding (both sum in f32 in the same order).
//!
//! Boundary: the volume is surrounded by the field's `outside` value (0 for extinction: empty
//! space; the smallest value for raw values), so every box holds (2R + 1)^3 values and the
//! faces of the volume read as open.

pub mod cpu;
pub mod estimate;
pub mod exact;
pub mod gpu;
pub mod stats;

use crate::classify::Classification;
use crate::error::{Error, Result};
use crate::gpu::Compute;
use crate::progress::Progress;
use crate::volume::Volume;
use std::borrow::Cow;

pub use estimate::Estimator;

/// Largest radius accepted, in voxels (a box of 513^3 voxels).
pub const MAX_RADIUS: u32 = 256;

/// Which scalar field the statistics run on.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum FieldKind {
    /// The classified extinction sigma_t at each voxel (what occludes light); outside is 0.
    #[default]
    Extinction,
    /// The volume's raw values; outside is their minimum.
    Value,
}

impl std::str::FromStr for FieldKind {
    type Err = Error;
    fn from_str(s: &str) -> Result<Self> {
        match s {
            "extinction" => Ok(Self::Extinction),
            "value" => Ok(Self::Value),
            other => Err(Error::param(
                "field",
                format!("unknown field '{other}'; known: extinction, value"),
            )),
        }
    }
}

/// A scalar field on a voxel grid and the value it takes outside the grid.
#[derive(Clone, Debug)]
pub struct ScalarField {
    pub values: Volume,
    pub outside: f32,
}

impl ScalarField {
    /// The field of `kind` for a volume and its classification.
    /// An owned volume is consumed (classified in place, or kept as the raw field), so that the
    /// volume and its field are not both held.
    pub fn new(
        volume: Cow<'_, Volume>,
        classification: &Classification,
        kind: FieldKind,
    ) -> Result<Self> {
        Ok(match kind {
            FieldKind::Extinction => Self {
                values: classification.into_extinction(volume)?,
                outside: 0.0,
            },
            FieldKind::Value => Self {
                outside: volume.value_range().0,
                values: volume.into_owned(),
            },
        })
    }

    /// The affine map of the field (outside included) onto [0, 1]. Every estimate is invariant
    /// under it, and statistics of values in [0, 1] neither overflow nor lose as much to
    /// rounding as those of raw values (a CT's 3000 HU squared), on either twin.
    pub fn unit_map(&self) -> UnitMap {
        let (lo, hi) = self.values.value_range();
        let (lo, hi) = (lo.min(self.outside) as f64, hi.max(self.outside) as f64);
        // In f64: hi - lo may overflow f32 for fields near its limits.
        let span = hi - lo;
        if span > 0.0 {
            UnitMap {
                scale: (1.0 / span) as f32,
                offset: (-lo / span) as f32,
                variance_scale: (span * span).min(f32::MAX as f64) as f32,
            }
        } else {
            UnitMap {
                scale: 0.0,
                offset: 0.0,
                variance_scale: 0.0,
            }
        }
    }
}

/// v -> v * scale + offset, and the factor that maps a variance of the mapped field back.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct UnitMap {
    pub scale: f32,
    pub offset: f32,
    pub variance_scale: f32,
}

impl UnitMap {
    /// The map that changes nothing.
    pub const IDENTITY: UnitMap = UnitMap {
        scale: 1.0,
        offset: 0.0,
        variance_scale: 1.0,
    };

    #[inline]
    pub fn apply(&self, v: f32) -> f32 {
        v * self.scale + self.offset
    }
}

/// Parameters of a VAO volume.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct VaoParams {
    /// Radius R of the tangent sphere in voxels; the box has side 2R + 1.
    pub radius: u32,
    pub estimator: Estimator,
    /// Also return the local variance (the `ao_variance` grid).
    pub variance: bool,
}

impl Default for VaoParams {
    fn default() -> Self {
        Self {
            radius: 10,
            estimator: Estimator::Cdf,
            variance: false,
        }
    }
}

impl VaoParams {
    pub fn validate(&self) -> Result<()> {
        if !(1..=MAX_RADIUS).contains(&self.radius) {
            return Err(Error::param(
                "radius",
                format!("must be in [1, {MAX_RADIUS}] voxels, got {}", self.radius),
            ));
        }
        if self.variance && self.estimator == Estimator::Exact {
            return Err(Error::param(
                "variance",
                "the exact estimator counts voxels and computes no variance",
            ));
        }
        Ok(())
    }
}

/// An AO volume: openness in [0, 1] per voxel (1 = unoccluded) and, on request, the local
/// variance of the field (VAO), the signed distance and the eight octant visibilities (the
/// geometric sweep), all on the field's grid.
pub struct AoVolume {
    pub openness: Volume,
    pub variance: Option<Volume>,
    pub sdf: Option<Volume>,
    /// Empty unless asked for; else V_s of octant s ([`crate::ao::sweep::padded`]'s order).
    pub octants: Vec<Volume>,
}

impl AoVolume {
    /// Openness and, if computed, the variance.
    pub fn new(openness: Volume, variance: Option<Volume>) -> Self {
        Self {
            openness,
            variance,
            sdf: None,
            octants: Vec::new(),
        }
    }
}

/// Computes the AO volume of `field` on the chosen device. The exact estimator is a reference
/// that counts voxels; it runs on the CPU whatever the device.
///
/// The CPU twin writes the openness over an owned field's values (a borrowed one is copied).
pub fn ao_volume(
    compute: &Compute,
    field: Cow<'_, ScalarField>,
    params: &VaoParams,
    progress: &dyn Progress,
) -> Result<AoVolume> {
    params.validate()?;
    if params.estimator == Estimator::Exact {
        let openness = exact::exact_volume(&field, params.radius, progress)?;
        return Ok(AoVolume::new(openness, None));
    }
    let map = field.unit_map();
    let mut ao = match compute {
        Compute::Cpu => cpu::ao_volume(field, map, params, progress)?,
        Compute::Gpu(ctx) => gpu::ao_volume(ctx, &field, map, params, progress)?,
    };
    if let Some(variance) = ao.variance.take() {
        let v = variance
            .values()
            .iter()
            .map(|&v| (v * map.variance_scale).min(f32::MAX))
            .collect();
        ao.variance = Some(Volume::new(
            variance.dims(),
            variance.spacing(),
            variance.origin(),
            v,
        )?);
    }
    Ok(ao)
}

/// The opacity factor of the paper's variance modulation, min(variance / variance_max, 1), per
/// voxel. `variance_max` None takes the volume's largest local variance (so the most varied
/// neighbourhood keeps its opacity); a variance that is zero everywhere gives factor 0.
pub fn opacity_modulation(variance: &Volume, variance_max: Option<f32>) -> Result<Volume> {
    let max = match variance_max {
        Some(m) if !(m > 0.0 && m.is_finite()) => {
            return Err(Error::param(
                "variance_max",
                format!("must be positive and finite, got {m}"),
            ))
        }
        Some(m) => m,
        None => variance.values().iter().copied().fold(0.0, f32::max),
    };
    let values = variance
        .values()
        .iter()
        .map(|&v| if max > 0.0 { (v / max).min(1.0) } else { 0.0 })
        .collect();
    Volume::new(
        variance.dims(),
        variance.spacing(),
        variance.origin(),
        values,
    )
}
