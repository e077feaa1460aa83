//! What a plan must meet (`method = "auto"`'s `error`, `scattering` and `pilot`, or `occlux plan
//! --error`): parsed with the scene, below the planner that meets it.

use crate::error::{Error, Result};
use serde::Serialize;

/// Default pilot image size (longer side, pixels).
pub const DEFAULT_PILOT: u32 = 64;
/// The light transport the truth models.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Scattering {
    /// Light scattered once (Cycles' default: no volume bounces).
    Single,
    /// A random walk of 8 bounces.
    Multiple,
}

impl Scattering {
    pub fn name(self) -> &'static str {
        match self {
            Scattering::Single => "single",
            Scattering::Multiple => "multiple",
        }
    }

    pub fn from_name(name: &str) -> Option<Self> {
        match name {
            "single" => Some(Scattering::Single),
            "multiple" => Some(Scattering::Multiple),
            _ => None,
        }
    }
}

impl std::str::FromStr for Scattering {
    type Err = Error;

    fn from_str(name: &str) -> Result<Self> {
        Scattering::from_name(name).ok_or_else(|| {
            Error::param(
                "scattering",
                format!("unknown '{name}': one of single, multiple"),
            )
        })
    }
}

/// What a plan must meet.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Budget {
    /// The largest relative RMSE over the volume's pixels against the truth.
    pub error: f64,
    pub scattering: Scattering,
    /// The pilot's image size (longer side, pixels).
    pub pilot: u32,
}

impl Budget {
    pub fn new(error: f64, scattering: Scattering) -> Self {
        Self {
            error,
            scattering,
            pilot: DEFAULT_PILOT,
        }
    }

    pub fn validate(&self) -> Result<()> {
        if !(self.error > 0.0 && self.error <= 10.0) {
            return Err(Error::param(
                "error",
                format!(
                    "the error budget (relative RMSE) must be in (0, 10], got {}",
                    self.error
                ),
            ));
        }
        if !(8..=1024).contains(&self.pilot) {
            return Err(Error::param(
                "pilot",
                format!(
                    "the pilot's image side must be in [8, 1024], got {}",
                    self.pilot
                ),
            ));
        }
        Ok(())
    }
}
