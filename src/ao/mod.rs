//! Ambient-occlusion volumes: per-voxel occlusion grids that renderers (and Blender, through
//! VDB) shade with. `vao` computes them fast from local statistics; `sweep` in eight octant
//! sweeps over the grid, either the paper's occlusion of an iso-surface from its signed
//! distance (geometric mode) or the visibility, the mean transmittance of the classified
//! extinction over all directions (physical mode);
//! `reference` holds the Monte Carlo references the fast methods are measured against.
//!
//! What the openness means ([`AoConvention`]): by default 1 = unoccluded, as Blender users
//! shade with it: empty space far from matter reads 1, an unoccluded flat surface 1, a crevice
//! and the air beside matter less. VAO's own openness (the paper's, 1/2 in empty space and on a
//! flat interface) stays available as `raw`; AO-shaded DVR shades with it.

pub mod reference;
pub mod surface_reference;
pub mod sweep;
pub mod vao;

use crate::classify::Classification;
use crate::error::{Error, Result};
use crate::gpu::Compute;
use crate::progress::Progress;
use crate::volume::Volume;
use serde::{Deserialize, Serialize};
use std::borrow::Cow;
use sweep::geometric::GeometricParams;
use sweep::sdf::SdfParams;
use vao::{AoVolume, Estimator, FieldKind, ScalarField, VaoParams};

/// How an AO volume is computed. By name in scene files, on the command line and in JSON: a
/// VAO estimator's (`cdf`, `gauss`, `gauss-exact`, `penner`, `exact`), `sweep` or
/// `sweep-physical` or `ordinates`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(try_from = "String", into = "&'static str")]
pub enum AoMethod {
    /// Openness from the local statistics of the tangent sphere (the VAO paper).
    Vao(Estimator),
    /// Occlusion sweeping's geometric mode: the ambient occlusion of an iso-surface from its
    /// signed distance ([`sweep::geometric`]), at any range; the signed distance on the CPU,
    /// the octants on CPU and GPU twins.
    Sweep,
    /// Occlusion sweeping's physical mode: the visibility, the mean transmittance of the
    /// classified extinction over all directions ([`sweep`]), at any range; CPU and GPU twins.
    SweepPhysical,
    /// The visibility by discrete ordinates ([`crate::transport`]): the mean transmittance over
    /// a set of directions, each swept across the grid along straight paths, at any range;
    /// CPU and GPU twins.
    Ordinates,
}

/// The default: the most accurate method whose cost is linear in the voxels (the visibility is
/// exact AO-shaded DVR under ambient light up to its error, which the discrete ordinates keep
/// free of the lattice walk's path-length bias; VAO's estimates are 0.7-1.9 from the truth).
impl Default for AoMethod {
    fn default() -> Self {
        AoMethod::Ordinates
    }
}

impl AoMethod {
    pub fn name(self) -> &'static str {
        match self {
            AoMethod::Vao(e) => e.name(),
            AoMethod::Sweep => "sweep",
            AoMethod::SweepPhysical => "sweep-physical",
            AoMethod::Ordinates => "ordinates",
        }
    }

    /// Peak memory of `occlux ao` with this method, as a multiple of the dense f32 volume: the
    /// volume, the method's working grids and the AO grid (`bench/memory.sh` at 512^3: VAO
    /// 1.40x, the physical sweep 2.04x, the ordinates 2.07x, the geometric sweep 2.09x; with a
    /// margin of about 0.1). The loaders refuse a volume whose peak would not fit.
    pub fn peak_volumes(self) -> f64 {
        match self {
            AoMethod::Vao(_) => 1.5,
            AoMethod::Sweep | AoMethod::SweepPhysical | AoMethod::Ordinates => 2.2,
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
            "sweep-physical" => Ok(AoMethod::SweepPhysical),
            "ordinates" => Ok(AoMethod::Ordinates),
            _ => s.parse().map(AoMethod::Vao).map_err(|_| {
                let vao: Vec<&str> = Estimator::ALL.iter().map(|e| e.name()).collect();
                Error::param(
                    "method",
                    format!(
                        "unknown AO method '{s}'; known: {}, sweep, sweep-physical, ordinates",
                        vao.join(", ")
                    ),
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

/// What an AO volume's openness means: the `ao` grid's convention.
///
/// VAO's openness F (the paper's) is the fraction of the tangent sphere, a ball of radius R
/// centred on the voxel, that holds less matter than the voxel, ties counting one half. On a flat
/// surface half the ball lies inside the matter, so an unoccluded surface reads 1/2; in empty
/// space every neighbour ties, so empty space reads 1/2 too (and the air beside matter less: the
/// "0.5 in empty air" of a Blender material). Ambient occlusion in Blender's sense counts only the
/// half ball above the tangent plane, the hemisphere a surface sees: `Unoccluded` is F over that
/// half ball, min(1, 2F). An unoccluded flat surface and empty space read 1; in a crevice, 2F is
/// the open share of the half ball; for a voxel in empty space, 2F is the share of its ball that
/// holds no matter. A convex point (open space below its tangent plane too) saturates at 1, as
/// a surface's hemisphere can be no more than fully open.
///
/// The sweeps already mean 1 = unoccluded (the geometric sweep's cosine-weighted hemisphere
/// about the normal: 1 on an open floor; the physical visibility: the mean transmittance over
/// all directions, 1 where nothing occludes, 1/2 on an opaque flat wall) and have no raw form.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum AoConvention {
    /// 1 = unoccluded: empty space and an unoccluded flat surface read 1 (VAO: min(1, 2F)).
    #[default]
    Unoccluded,
    /// VAO's openness F as the paper defines it: 1/2 in empty space and on a flat interface.
    Raw,
}

impl AoConvention {
    pub const ALL: [AoConvention; 2] = [AoConvention::Unoccluded, AoConvention::Raw];

    pub fn name(self) -> &'static str {
        match self {
            AoConvention::Unoccluded => "unoccluded",
            AoConvention::Raw => "raw",
        }
    }

    /// `method`'s openness, as it computes it (VAO: the raw F), in this convention.
    pub fn apply(self, method: AoMethod, openness: Volume) -> Result<Volume> {
        match (self, method) {
            (AoConvention::Unoccluded, AoMethod::Vao(_)) => unoccluded(openness),
            _ => Ok(openness),
        }
    }
}

impl std::str::FromStr for AoConvention {
    type Err = Error;
    fn from_str(s: &str) -> Result<Self> {
        Self::ALL
            .into_iter()
            .find(|c| c.name() == s)
            .ok_or_else(|| {
                Error::param(
                    "convention",
                    format!("unknown AO convention '{s}'; known: unoccluded, raw"),
                )
            })
    }
}

/// VAO's raw openness F normalised by the half ball above the tangent plane: min(1, 2F)
/// ([`AoConvention`]), on the same grid.
pub fn unoccluded(raw: Volume) -> Result<Volume> {
    let (dims, spacing, origin) = (raw.dims(), raw.spacing(), raw.origin());
    let values = raw
        .into_values()
        .into_iter()
        .map(|f| (2.0 * f).min(1.0))
        .collect();
    Volume::new(dims, spacing, origin, values)
}

/// An AO volume's parameters.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AoVolumeParams {
    pub method: AoMethod,
    /// VAO's tangent-sphere radius in voxels (the sweeps reach the whole volume).
    pub radius: u32,
    /// The field VAO's statistics run on (the sweeps read the classified extinction).
    pub field: FieldKind,
    /// Also return the local variance (VAO only).
    pub variance: bool,
    /// The geometric sweep's surface: the raw value's iso-surface; `None`: the classified
    /// extinction's half-maximum surface (sigma_t = max sigma_t / 2 over the volume, as edges
    /// are found at half maximum in imaging), which needs no knowledge of the data's units.
    pub iso: Option<f32>,
    /// The geometric sweep's shading (gamma, octant intensities, translucency).
    pub geometric: GeometricParams,
    /// Also return the eight octant visibilities (geometric sweep).
    pub octants: bool,
    /// What the openness means: 1 = unoccluded (default), or VAO's raw openness.
    pub convention: AoConvention,
    /// The discrete ordinates' directions ([`crate::transport::DEFAULT_DIRECTIONS`]).
    pub directions: u32,
}

impl Default for AoVolumeParams {
    fn default() -> Self {
        let vao = VaoParams::default();
        Self {
            method: AoMethod::default(),
            radius: vao.radius,
            field: FieldKind::default(),
            variance: vao.variance,
            iso: None,
            geometric: GeometricParams::default(),
            octants: false,
            convention: AoConvention::default(),
            directions: crate::transport::DEFAULT_DIRECTIONS,
        }
    }
}

impl AoVolumeParams {
    /// Peak memory of the AO volume's computation, as a multiple of the dense f32 volume:
    /// the method's ([`AoMethod::peak_volumes`]), the variance grid and, for the geometric
    /// sweep, the eight octant grids when kept.
    pub fn peak_volumes(&self) -> f64 {
        let variance = f64::from(u8::from(
            self.variance && matches!(self.method, AoMethod::Vao(_)),
        ));
        let octants = if self.octants && self.method == AoMethod::Sweep {
            8.0
        } else {
            0.0
        };
        self.method.peak_volumes() + variance + octants
    }

    /// VAO's parameters, for a VAO method.
    pub fn vao(&self) -> Option<VaoParams> {
        match self.method {
            AoMethod::Vao(estimator) => Some(VaoParams {
                radius: self.radius,
                estimator,
                variance: self.variance,
            }),
            AoMethod::Sweep | AoMethod::SweepPhysical | AoMethod::Ordinates => None,
        }
    }

    pub fn validate(&self) -> Result<()> {
        self.refuse_foreign()?;
        if let Some(vao) = self.vao() {
            return vao.validate();
        }
        if self.convention == AoConvention::Raw {
            return Err(Error::param(
                "convention",
                "raw is VAO's own openness (1/2 in empty space); the sweeps' AO already reads 1 \
                 where nothing occludes",
            ));
        }
        if self.field != FieldKind::Extinction {
            return Err(Error::param(
                "field",
                "the sweeps read the classified extinction (or --iso for a raw value's surface)",
            ));
        }
        if self.variance {
            return Err(Error::param(
                "variance",
                "the sweeps compute no local variance (VAO's statistics do)",
            ));
        }
        if self.method != AoMethod::Sweep && self.octants {
            return Err(Error::param(
                "octants",
                "only the geometric sweep keeps octant grids",
            ));
        }
        if self.method == AoMethod::Ordinates {
            let range = crate::transport::directions::MIN_DIRECTIONS
                ..=crate::transport::directions::MAX_DIRECTIONS;
            if !range.contains(&self.directions) {
                return Err(Error::param(
                    "directions",
                    format!(
                        "must lie in [{}, {}], got {}",
                        range.start(),
                        range.end(),
                        self.directions
                    ),
                ));
            }
        }
        if let Some(iso) = self.iso {
            if !iso.is_finite() {
                return Err(Error::param("iso", format!("must be finite, got {iso}")));
            }
        }
        self.geometric.validate()
    }

    /// Refuses a parameter that only another method reads, rather than ignoring it (`--method
    /// cdf --iso 5` computed VAO as if no iso-surface were given): each is either left at its
    /// default or given to a method that reads it.
    fn refuse_foreign(&self) -> Result<()> {
        let defaults = Self::default();
        let foreign = [
            (
                "iso",
                self.iso.is_some() && self.method != AoMethod::Sweep,
                "only the geometric sweep (method sweep) reads an iso-surface",
            ),
            (
                "gamma, alpha, octant intensities, combined",
                self.geometric != defaults.geometric && self.method != AoMethod::Sweep,
                "only the geometric sweep (method sweep) shades with them",
            ),
            (
                "directions",
                self.directions != defaults.directions && self.method != AoMethod::Ordinates,
                "only the discrete ordinates (method ordinates) take directions",
            ),
            (
                "radius",
                self.radius != defaults.radius && self.vao().is_none(),
                "only VAO's estimators (cdf, gauss, ...) take a radius; the sweeps reach the whole \
                 volume",
            ),
        ];
        match foreign.into_iter().find(|(_, given, _)| *given) {
            Some((key, _, why)) => Err(Error::param(
                key,
                format!("{why}; method {} would ignore it", self.method.name()),
            )),
            None => Ok(()),
        }
    }

    /// The field the geometric sweep measures distances on, and its signed distance's
    /// parameters: the raw values at `iso`, or the classified extinction at half its maximum.
    fn surface(
        &self,
        volume: Cow<'_, Volume>,
        classification: &Classification,
    ) -> Result<(Volume, SdfParams)> {
        let (field, iso) = match self.iso {
            Some(iso) => (volume.into_owned(), iso),
            None => {
                let extinction = classification.into_extinction(volume)?;
                let (_, max) = extinction.value_range();
                if max <= 0.0 {
                    return Err(Error::Volume(
                        "the classification makes the whole volume transparent: there is no \
                         surface to occlude (give the sweep an iso-value of the raw data)"
                            .into(),
                    ));
                }
                (extinction, 0.5 * max)
            }
        };
        Ok((
            field,
            SdfParams {
                iso,
                ..Default::default()
            },
        ))
    }
}

/// The AO volume of a classified volume: `openness` (1 = unoccluded, in `params.convention`) on
/// its grid, and the local variance, signed distance and octant visibilities when the method
/// gives them, on `compute` (VAO's exact count always on the CPU, the geometric sweep's signed
/// distance too). An owned `volume` is consumed as the method's field is made from it, so that
/// the peak holds the field, not the volume beside it.
pub fn ao_volume(
    compute: &Compute,
    volume: Cow<'_, Volume>,
    classification: &Classification,
    params: &AoVolumeParams,
    progress: &dyn Progress,
) -> Result<AoVolume> {
    params.validate()?;
    if let Some(vao) = params.vao() {
        let field = ScalarField::new(volume, classification, params.field)?;
        let mut ao = vao::ao_volume(compute, Cow::Owned(field), &vao, progress)?;
        ao.openness = params.convention.apply(params.method, ao.openness)?;
        return Ok(ao);
    }
    if params.method == AoMethod::Sweep {
        let (field, surface) = params.surface(volume, classification)?;
        let swept = sweep::geometric::occlusion_from(
            compute,
            Cow::Owned(field),
            &surface,
            &params.geometric,
            params.octants,
            progress,
        )?;
        return Ok(AoVolume {
            openness: swept.ao,
            variance: None,
            sdf: Some(swept.sdf.sdf),
            octants: swept.octants.unwrap_or_default(),
        });
    }
    let extinction = classification.into_extinction(volume)?;
    let visibility = if params.method == AoMethod::Ordinates {
        crate::transport::visibility(compute, &extinction, params.directions, progress)?
    } else {
        sweep::physical::visibility(compute, &extinction, progress)?
    };
    Ok(AoVolume::new(visibility, None))
}
