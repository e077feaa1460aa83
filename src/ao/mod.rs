//! Ambient-occlusion volumes: per-voxel occlusion grids that renderers (and Blender, through
//! VDB) shade with. `vao` computes them fast from local statistics; `sweep` computes the
//! visibility, the mean transmittance over all directions, in eight sweeps (both with CPU and
//! GPU twins);
//! `reference` holds the Monte Carlo references the fast methods are measured against.

pub mod commands;
pub mod reference;
pub mod sweep;
pub mod vao;

use crate::classify::Classification;
use crate::error::{Error, Result};
use crate::gpu::Compute;
use crate::progress::Progress;
use crate::volume::Volume;
use serde::{Deserialize, Serialize};
use vao::{AoVolume, Estimator, FieldKind, ScalarField, VaoParams};

/// How an AO volume is computed. By name in scene files, on the command line and in JSON: a
/// VAO estimator's (`cdf`, `gauss`, `gauss-exact`, `penner`, `exact`) or `sweep`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(try_from = "String", into = "&'static str")]
pub enum AoMethod {
    /// Openness from the local statistics of the tangent sphere (the VAO paper).
    Vao(Estimator),
    /// Visibility: the mean transmittance of the classified extinction over all directions,
    /// by the occlusion sweep ([`sweep`]), at any range; CPU and GPU twins.
    Sweep,
}

impl Default for AoMethod {
    fn default() -> Self {
        AoMethod::Vao(Estimator::default())
    }
}

impl AoMethod {
    pub fn name(self) -> &'static str {
        match self {
            AoMethod::Vao(e) => e.name(),
            AoMethod::Sweep => "sweep",
        }
    }

    /// Whether it runs on the CPU whatever the device (the exact count, a reference).
    pub fn cpu_only(self) -> bool {
        self == AoMethod::Vao(Estimator::Exact)
    }
}

impl std::str::FromStr for AoMethod {
    type Err = Error;
    fn from_str(s: &str) -> Result<Self> {
        match s {
            "sweep" => Ok(AoMethod::Sweep),
            _ => s.parse().map(AoMethod::Vao).map_err(|_| {
                let vao: Vec<&str> = Estimator::ALL.iter().map(|e| e.name()).collect();
                Error::param(
                    "method",
                    format!("unknown AO method '{s}'; known: {}, sweep", vao.join(", ")),
                )
            }),
        }
    }
}

impl TryFrom<String> for AoMethod {
    type Error = Error;
    fn try_from(s: String) -> Result<Self> {
        s.parse()
    }
}

impl From<AoMethod> for &'static str {
    fn from(m: AoMethod) -> Self {
        m.name()
    }
}

/// An AO volume's parameters.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AoVolumeParams {
    pub method: AoMethod,
    /// VAO's tangent-sphere radius in voxels (the sweep reaches the whole volume).
    pub radius: u32,
    /// The field VAO's statistics run on (the sweep reads the extinction).
    pub field: FieldKind,
    /// Also return the local variance (VAO only).
    pub variance: bool,
}

impl AoVolumeParams {
    /// VAO's parameters, for a VAO method.
    pub fn vao(&self) -> Option<VaoParams> {
        match self.method {
            AoMethod::Vao(estimator) => Some(VaoParams {
                radius: self.radius,
                estimator,
                variance: self.variance,
            }),
            AoMethod::Sweep => None,
        }
    }

    pub fn validate(&self) -> Result<()> {
        match self.vao() {
            Some(vao) => vao.validate(),
            None if self.field != FieldKind::Extinction => Err(Error::param(
                "field",
                "the sweep's visibility is a transmittance: it reads the extinction only",
            )),
            None if self.variance => Err(Error::param(
                "variance",
                "the sweep computes no local variance (VAO's statistics do)",
            )),
            None => Ok(()),
        }
    }
}

/// The AO volume of a classified volume: `openness` (1 = unoccluded) on its grid, and the
/// local variance when asked for, on `compute` (VAO's exact count always on the CPU).
pub fn ao_volume(
    compute: &Compute,
    volume: &Volume,
    classification: &Classification,
    params: &AoVolumeParams,
    progress: &dyn Progress,
) -> Result<AoVolume> {
    params.validate()?;
    match params.vao() {
        Some(vao) => {
            let field = ScalarField::new(volume, classification, params.field)?;
            vao::ao_volume(compute, &field, &vao, progress)
        }
        None => {
            let extinction = classification.extinction(volume)?;
            Ok(AoVolume {
                openness: sweep::visibility(compute, &extinction, progress)?,
                variance: None,
            })
        }
    }
}
