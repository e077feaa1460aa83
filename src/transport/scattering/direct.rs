//! The light that reaches each cell unscattered: the first source of the iteration.
//!
//! A sun's transmittance is one ordinate swept across the grid towards it (the visibility
//! sweep with a single direction: straight paths, bilinear upwind, trapezoid extinction). A
//! lamp's rays fan out from a point, which no plane sweep follows, so each cell marches
//! towards the lamp instead (midpoint rule, half a cell per step, trilinear extinction), from
//! its centre to the lamp or to the grid's box, whichever comes first.

use crate::error::Result;
use crate::lights::{incident, Light};
use crate::progress::Progress;
use crate::transport::directions::Ordinates;
use crate::transport::medium::Medium;
use crate::volume::Volume;
use glam::Vec3;
use rayon::prelude::*;

/// Per cell, the direction towards the light and the irradiance that reaches it through the
/// medium. Near a lamp the irradiance is taken at half a cell's distance at least: the cell
/// holding the lamp stands for its whole volume, over which 1 / r^2 has a finite mean, not
/// for its centre.
pub struct Direct {
    pub towards: Vec<Vec3>,
    pub irradiance: Vec<Vec3>,
}

pub fn direct(medium: &Medium, light: &Light, progress: &dyn Progress) -> Result<Direct> {
    let grid = &medium.extinction;
    let transmittance = transmittance(grid, light, progress)?;
    let nearest = nearest(grid);
    let (towards, irradiance) = (0..transmittance.len())
        .into_par_iter()
        .map(|cell| match reaching(light, grid.centre(cell), nearest) {
            Some((to, e)) => (to, e * transmittance[cell]),
            None => (Vec3::Z, Vec3::ZERO),
        })
        .unzip();
    Ok(Direct {
        towards,
        irradiance,
    })
}

/// The transmittance of `light` from where it enters `grid` (sigma_t per world unit at each
/// cell centre) to each cell's centre; 0 for ambient light, which has no one direction.
pub fn transmittance(grid: &Volume, light: &Light, progress: &dyn Progress) -> Result<Vec<f32>> {
    let cells = grid.values().len();
    Ok(match *light {
        Light::Directional { to_light, .. } => {
            let sun = Ordinates::single(to_light.normalize(), grid.spacing());
            crate::transport::cpu::visibility(grid, &sun, progress)?.into_values()
        }
        Light::Point { position, .. } => (0..cells)
            .into_par_iter()
            .map(|cell| march(grid, grid.centre(cell), position))
            .collect(),
        Light::Ambient { .. } => vec![0.0; cells],
    })
}

/// How near a lamp a cell of `grid` is taken to be at most: half its smallest side.
pub fn nearest(grid: &Volume) -> f32 {
    0.5 * grid.spacing().min_element()
}

/// The direction towards `light` and its unattenuated irradiance at cell centre `x`, a lamp
/// taken at `nearest` at least (see [`Direct`]).
pub fn reaching(light: &Light, x: Vec3, nearest: f32) -> Option<(Vec3, Vec3)> {
    let seen_from = match *light {
        Light::Point { position, .. } if (position - x).length() < nearest => {
            position - (position - x).normalize_or(Vec3::Z) * nearest
        }
        _ => x,
    };
    incident(light, seen_from)
}

/// Transmittance from `x` to `lamp` through the medium, within the grid's box.
fn march(grid: &Volume, x: Vec3, lamp: Vec3) -> f32 {
    let to = lamp - x;
    let distance = to.length();
    if distance <= 0.0 {
        return 1.0;
    }
    let dir = to / distance;
    let (lo, hi) = grid.bounds();
    // Where the ray leaves the box (x is inside it): the nearest exit across the three slabs.
    let exit = (0..3)
        .filter(|&a| dir[a] != 0.0)
        .map(|a| {
            let wall = if dir[a] > 0.0 { hi[a] } else { lo[a] };
            ((wall - x[a]) / dir[a]).max(0.0)
        })
        .fold(f32::INFINITY, f32::min);
    let length = distance.min(exit);
    let step = 0.5 * grid.spacing().min_element();
    let steps = (length / step).ceil().max(1.0) as usize;
    let dt = length / steps as f32;
    let depth: f32 = (0..steps)
        .map(|s| grid.sample(x + dir * ((s as f32 + 0.5) * dt)))
        .sum::<f32>()
        * dt;
    (-depth).exp()
}
