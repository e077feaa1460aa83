//! Baked light (`occlux bake`, `occlux.bake`): the grids that let any renderer shade every
//! point of a volume without tracing a shadow ray, each per unit strength of its light so that
//! a material scales it by the light's live strength and colour:
//! - `ao`: the ambient visibility V(x), the mean transmittance over all directions (discrete
//!   ordinates, [`crate::transport`]); under uniform ambient radiance L the single-scattered
//!   radiance at x is L V(x) for an isotropic phase;
//! - `light{i}`, per sun or lamp i of the scene's lights (in their order, ambient lights
//!   skipped): the irradiance that reaches x through the medium per unit of the light's
//!   strength, T(x) for a sun (unit irradiance) and T(x) / r^2 for a lamp (unit intensity;
//!   within half a cell of the lamp at half a cell); its single-scattered radiance for an
//!   isotropic phase is strength x `light{i}` / 4 pi;
//! - `light{i}_multiple_r`, `_g`, `_b` (with `multiple`): the mean over directions of the
//!   radiance scattered into x of light that has scattered at least once before
//!   ([`crate::transport::scattering`], 8 bounces as the `multiple` reference), per unit
//!   strength and colour channel (the albedo of every earlier scattering is in it), on the
//!   solver's coarser grid;
//! - `ao_multiple_r`, `_g`, `_b` (with `multiple`): the same for uniform white ambient light of
//!   unit radiance, whose light scattered once is `ao` itself
//!   ([`crate::transport::scattering::ambient_in_scattered`]).
//!
//! A renderer adds, per unit length, sigma_s(x) (world x (`ao` + `ao_multiple`) + sum_i
//! strength_i colour_i (`light{i}` / 4 pi + `light{i}_multiple`)) as emission, with sigma_s = albedo x sigma_t of
//! the classification, and leaves the baked lights out of the volume's direct lighting.
//! Moving a light or changing the classification needs a new bake; its strength and colour do
//! not.

use crate::classify::Classification;
use crate::error::{Error, Result};
use crate::gpu::Compute;
use crate::lights::{Light, Lighting};
use crate::progress::{Cancel, Progress};
use crate::render::ipsvi::{transport_coarsen, TRANSPORT_DIRECTIONS};
use crate::render::reference::DEFAULT_BOUNCES;
use crate::transport::medium::Medium;
use crate::transport::scattering::direct::{nearest, reaching, transmittance};
use crate::transport::scattering::{ambient_in_scattered, in_scattered, ScatteringParams};
use crate::volume::Volume;
use glam::Vec3;
use rayon::prelude::*;

/// The ambient visibility's grid.
pub const AO: &str = crate::render::ao_shaded::AO_GRID;
/// The colour channels' suffixes of the multiply scattered light's grids.
pub const CHANNELS: [&str; 3] = ["r", "g", "b"];

/// The grids of ambient light's multiply scattered light, red, green and blue.
pub fn ambient_multiple_grids() -> [String; 3] {
    CHANNELS.map(|c| format!("{AO}_multiple_{c}"))
}

/// The grid of the light reaching each point from baked light `index`.
pub fn light_grid(index: usize) -> String {
    format!("light{index}")
}

/// The grids of baked light `index`'s multiply scattered light, red, green and blue.
pub fn multiple_grids(index: usize) -> [String; 3] {
    CHANNELS.map(|c| format!("light{index}_multiple_{c}"))
}

/// What a bake computes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BakeParams {
    /// Directions of the ambient visibility ([`crate::transport::DEFAULT_DIRECTIONS`]).
    pub directions: u32,
    /// Also the multiply scattered light of ambient light and of each sun and lamp.
    pub multiple: bool,
    /// Henyey-Greenstein asymmetry of the multiple scattering, in (-1, 1).
    pub g: f32,
}

impl Default for BakeParams {
    fn default() -> Self {
        Self {
            directions: crate::transport::DEFAULT_DIRECTIONS,
            multiple: true,
            g: 0.0,
        }
    }
}

/// One sun's or lamp's grids.
pub struct BakedLight {
    /// The light as the scene gives it (its strength and colour: what the grids are per unit
    /// of).
    pub light: Light,
    /// Its index among the scene's lights.
    pub scene_index: usize,
    /// Irradiance per unit strength reaching each voxel.
    pub reaching: Volume,
    /// Multiply scattered light per unit strength, per channel, on the solver's grid.
    pub multiple: Option<[Volume; 3]>,
}

/// A bake's grids, on the volume's grid but for the multiply scattered light.
pub struct Baked {
    /// The classified extinction the bake read (the VDB's `density`).
    pub extinction: Volume,
    pub ao: Volume,
    /// Ambient light's multiply scattered light per unit radiance, per channel, on the
    /// solver's grid.
    pub ao_multiple: Option<[Volume; 3]>,
    pub lights: Vec<BakedLight>,
}

impl Baked {
    /// Every grid by name, in order: `ao` and its multiple grids, then per light `light{i}` and
    /// its multiple grids.
    pub fn grids(&self) -> Vec<(String, &Volume)> {
        named(
            &self.ao,
            self.ao_multiple.as_ref().map(|m| m.each_ref()),
            self.lights
                .iter()
                .map(|l| (&l.reaching, l.multiple.as_ref().map(|m| m.each_ref()))),
        )
    }

    /// [`Baked::grids`], owned.
    pub fn into_grids(self) -> Vec<(String, Volume)> {
        named(
            self.ao,
            self.ao_multiple,
            self.lights.into_iter().map(|l| (l.reaching, l.multiple)),
        )
    }
}

/// `ao` and its multiple grids, then per light its reaching light and its multiple grids,
/// named.
fn named<V>(
    ao: V,
    ao_multiple: Option<[V; 3]>,
    lights: impl Iterator<Item = (V, Option<[V; 3]>)>,
) -> Vec<(String, V)> {
    let mut grids = vec![(AO.to_owned(), ao)];
    if let Some(multiple) = ao_multiple {
        grids.extend(ambient_multiple_grids().into_iter().zip(multiple));
    }
    for (i, (reaching, multiple)) in lights.enumerate() {
        grids.push((light_grid(i), reaching));
        if let Some(multiple) = multiple {
            grids.extend(multiple_grids(i).into_iter().zip(multiple));
        }
    }
    grids
}

/// The light a unit of `light`'s strength is: white, irradiance 1 for a sun and intensity 1
/// for a lamp; None for ambient light (the `ao` grid covers it).
fn unit(light: &Light) -> Option<Light> {
    match *light {
        Light::Directional { to_light, .. } => Some(Light::Directional {
            to_light,
            irradiance: Vec3::ONE,
        }),
        Light::Point { position, .. } => Some(Light::Point {
            position,
            intensity: Vec3::ONE,
        }),
        Light::Ambient { .. } => None,
    }
}

/// The stages [`bake`] reports progress in: the visibility and (with `multiple`) its multiple
/// scattering, then per sun or lamp its reaching light and (with `multiple`) its multiple
/// scattering.
pub fn stages(lighting: &Lighting, params: &BakeParams) -> u64 {
    let lamps = lighting.lights.iter().filter_map(unit).count() as u64;
    (1 + lamps) * (1 + params.multiple as u64)
}

/// Bakes the light of `lighting` into grids of `volume` classified by `classification`, on
/// `compute`. `progress` counts [`stages`].
pub fn bake(
    compute: &Compute,
    volume: &Volume,
    classification: &Classification,
    lighting: &Lighting,
    params: &BakeParams,
    progress: &dyn Progress,
) -> Result<Baked> {
    lighting.validate()?;
    crate::optics::phase::G.check(params.g as f64)?;
    let units: Vec<(usize, Light)> = lighting
        .lights
        .iter()
        .enumerate()
        .filter_map(|(i, l)| Some((i, unit(l)?)))
        .collect();
    let total = stages(lighting, params);
    let mut done = 0;
    let mut step = |progress: &dyn Progress| {
        done += 1;
        progress.update(done, total);
    };
    let extinction = classification.extinction(volume)?;
    let ao =
        crate::transport::visibility(compute, &extinction, params.directions, &Cancel(progress))?;
    step(progress);
    let medium = if params.multiple {
        let lut = classification.bake(volume);
        Some(Medium::classify(
            volume,
            &lut,
            transport_coarsen(volume.dims()),
        )?)
    } else {
        None
    };
    let gpu = match compute {
        Compute::Gpu(ctx) => Some(&**ctx),
        Compute::Cpu => None,
    };
    let scattering = ScatteringParams {
        directions: TRANSPORT_DIRECTIONS,
        bounces: DEFAULT_BOUNCES,
        g: params.g,
    };
    let ao_multiple = match &medium {
        Some(medium) => {
            let field = ambient_in_scattered(gpu, medium, &ao, &scattering, &Cancel(progress))?;
            step(progress);
            Some(per_channel_means(&field.grid, &field.bands)?)
        }
        None => None,
    };
    let mut lights = Vec::with_capacity(units.len());
    for (scene_index, unit_light) in units {
        if progress.cancelled() {
            return Err(Error::Cancelled);
        }
        let reaching = reaching_light(&extinction, &unit_light, &Cancel(progress))?;
        step(progress);
        let multiple = match &medium {
            Some(medium) => {
                let field = in_scattered(gpu, medium, &unit_light, &scattering, &Cancel(progress))?;
                step(progress);
                Some(per_channel_means(&field.grid, &field.bands)?)
            }
            None => None,
        };
        lights.push(BakedLight {
            light: lighting.lights[scene_index],
            scene_index,
            reaching,
            multiple,
        });
    }
    Ok(Baked {
        extinction,
        ao,
        ao_multiple,
        lights,
    })
}

/// The irradiance of `light` (a unit light) reaching each voxel centre of `extinction`.
fn reaching_light(extinction: &Volume, light: &Light, progress: &dyn Progress) -> Result<Volume> {
    let t = transmittance(extinction, light, progress)?;
    let nearest = nearest(extinction);
    let values: Vec<f32> = t
        .par_iter()
        .enumerate()
        .map(
            |(cell, t)| match reaching(light, extinction.centre(cell), nearest) {
                // A unit light is white: every channel holds the same irradiance.
                Some((_, e)) => e.x * t,
                None => 0.0,
            },
        )
        .collect();
    Volume::new(
        extinction.dims(),
        extinction.spacing(),
        extinction.origin(),
        values,
    )
}

/// Band 0 of each channel of `bands` (J's mean over directions) as three volumes on `grid`.
fn per_channel_means(
    grid: &Volume,
    bands: &crate::transport::scattering::bands::Bands,
) -> Result<[Volume; 3]> {
    let cells = grid.values().len();
    let channel = |c: usize| -> Result<Volume> {
        let values = (0..cells).map(|cell| bands.mean(cell)[c]).collect();
        Volume::new(grid.dims(), grid.spacing(), grid.origin(), values)
    };
    Ok([channel(0)?, channel(1)?, channel(2)?])
}
