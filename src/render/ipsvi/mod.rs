//! Image plane sweep volume illumination (Sundén, Ynnerman, Ropinski 2011): single scattering
//! with shadows from directional and point lights, computed inside the ray caster's one pass.
//!
//! The image is rendered line by line in an order ([`sweep`]) in which every light ray's image
//! is crossed from the light's side onwards. A 2D illumination cache over the light's rays
//! ([`cache`]) carries the light from line to line: each sample finds its texel by projecting
//! along the light, reads the light that earlier lines let through there (illumIn), lights
//! itself with it, and the ray writes what reaches it (illumOut) when it leaves the texel.
//! Reads come from the cache as the previous lines left it and a line's writes are merged
//! after it (the paper's ping-pong), so the pixels of a line are independent.
//!
//! The optical model is the Monte Carlo `single` reference's (Eq. 2 of the paper, I_ss):
//! front-to-back compositing as the ray caster's (steps of `step` shifted per pixel as
//! [`crate::render::steps`] says, midpoint samples, opacity
//! 1 - exp(-sigma_t dt), early ray termination), and a sample at x scatters
//! `albedo * p_HG(g, l . d) * E_l(x) * T_l(x)` towards the eye per unit opacity, T_l being the
//! transmittance of the light from where it enters the volume's box to x.
//!
//! How T_l(x) is found:
//! - `piecewise` (default): a cache entry holds the optical depth the light has crossed and how
//!   far along its ray it had travelled (`s`). On each of the four cache rays around x, the
//!   sample takes the nearest usable entry behind it, the cache's entry for that texel or the
//!   last one its own view ray wrote there, whichever has the larger `s <= s(x)`, and adds the
//!   extinction integrated along that cache ray from x's travel back to the entry's (midpoint
//!   rule, steps of `step`); with no usable entry it integrates back to the box. The four
//!   depths are interpolated bilinearly and T_l(x) = exp(-depth). So the light on every cache
//!   ray is that ray's shadow integral, cut into pieces shared between lines; the approximation
//!   is only the interpolation between rays a texel apart. The order of the sweep, early ray
//!   termination and material outside the image change only how long the pieces are (the
//!   cost), never which light is found; the same holds when the light lies along the view and
//!   every ray carries its own light.
//! - without it (the paper's basic scheme): T_l(x) is the nearest entry's transmittance as
//!   read, and a sample lets through `T_l (1 - alpha)`, alpha being its opacity along the view ray: the
//!   light is attenuated by the material the view rays happened to cross in its texel, not by
//!   the light's own path. Cheaper, and wrong where view and light paths differ in length.
//!
//! `scattering = "multiple"` adds the light scattered more than once ([`diffusion`]): a sample
//! also scatters `albedo * E_l(x) * phi / (4 pi)`, phi being the diffuse fluence of a beam in a
//! slab along the light ray, at the depth -ln T_l(x) of a slab as deep as the light ray's path
//! through the box (each texel's chord, integrated once per light before its sweep and
//! interpolated as T_l is). It costs a few exponentials per sample, the chord pass over the
//! cache's texels, and one f32 per texel.
//!
//! Outputs: the image, depth (where the view transmittance falls through 0.5, as the ray
//! caster's) and the `shadow` layer ([`crate::render::Factor`]): P, the lights' transmittance
//! at each sample weighted by the sample's contribution `T alpha` and summed along the ray,
//! beside its coverage A = 1 - T at the end (the image's alpha). Several lights are swept one
//! after the other (single scattering is linear in the lights); emission and background are
//! added once. Each light's pass gathers its own `P_l = sum T alpha T_l` and a weight
//! `W_l = sum T alpha E_l` (its grey irradiance with the same weights), and the layer is the
//! weighted mean `P = sum_l W_l P_l / sum_l W_l`: exactly `sum T alpha f` with
//! `f = sum_l E_l T_l / sum_l E_l` (the lights' transmittance weighted by their irradiance at
//! the sample) for one light and for any number of suns (whose irradiance does not vary), and
//! that with each lamp's irradiance averaged along the ray when lamps are mixed with other
//! lights (the passes cannot share a sample's irradiances). Where no light reaches the
//! covered samples (lights of no irradiance) P = A.
//! Extra memory: two u64 per cache texel, one f32 more with multiple scattering (the cache,
//! its merge list and the chords grow with the image, not with the volume); on the GPU also a
//! u32 per texel (the texels a line wrote) and a list of a line's writes (at most 64 MiB: long
//! lines are traced in pieces).
//!
//! `cpu` and `gpu` are twins that render the same image (tests/ipsvi_twins.rs states how
//! closely and why).

pub mod cache;
pub mod cpu;
pub mod diffusion;
pub mod gpu;
mod method;
pub mod sweep;

use crate::camera::Camera;
use crate::classify::Lut;
use crate::error::{Error, Result};
use crate::lights::{Light, Lighting};
use crate::method::RenderMethod;
use crate::progress::Progress;
use crate::render::{Factor, RenderImage, BACKGROUND_DEPTH};
use crate::volume::Volume;
use cache::{CacheMap, Resolution};
use glam::Vec3;
use serde::{Deserialize, Serialize};
use sweep::{Lines, Shape};

/// Largest cache side accepted (8192^2 texels are 512 MiB of entries).
pub const MAX_CACHE_SIZE: u32 = 8192;

/// Parameters of IPSVI: `method = "ipsvi"` in a scene, one key per field.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct IpsviParams {
    /// Texels along the cache's longer side; None: texels half a pixel wide at the volume's
    /// centre, at most a voxel ([`Resolution::for_view`]).
    pub cache_size: Option<u32>,
    /// Rings or columns of pixels per line after the first (which is one pixel wide).
    pub line_width: u32,
    /// Integrate the light along its own path back to the entry read (see the module docs).
    pub piecewise: bool,
    /// Henyey-Greenstein asymmetry, in (-1, 1).
    pub g: f32,
    /// Step along each ray and light path in world units; None: half the smallest voxel spacing.
    pub step: Option<f32>,
    /// Early ray termination: stop a view ray when its transmittance falls below this.
    pub ert_threshold: f32,
    /// Single scattering, or with the diffuse light of [`diffusion`] added.
    pub scattering: Scattering,
}

/// Which scattered light IPSVI renders.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Scattering {
    /// The light's first scattering towards the eye (the `single` reference's model).
    #[default]
    Single,
    /// Also the light scattered before, as diffuse fluence along each light ray (the
    /// `multiple` reference's model, approximated).
    Multiple,
    /// Also the light scattered before, solved on the grid by discrete ordinates
    /// ([`crate::transport::scattering`]; the `multiple` reference's model).
    Transport,
}

impl std::str::FromStr for Scattering {
    type Err = crate::error::Error;

    fn from_str(name: &str) -> crate::error::Result<Self> {
        let choices = [
            ("single", Scattering::Single),
            ("multiple", Scattering::Multiple),
            ("transport", Scattering::Transport),
        ];
        crate::names::parse_name("scattering", name, &choices)
    }
}

impl Default for IpsviParams {
    fn default() -> Self {
        Self {
            cache_size: None,
            line_width: 1,
            piecewise: true,
            g: 0.0,
            step: None,
            ert_threshold: 1e-3,
            scattering: Scattering::Single,
        }
    }
}

impl IpsviParams {
    /// Checks every parameter against its registry range.
    pub fn validate(&self) -> Result<()> {
        if let Some(size) = self.cache_size {
            method::CACHE_SIZE.check(size as f64)?;
        }
        method::LINE_WIDTH.check(self.line_width as f64)?;
        crate::optics::phase::G.check(self.g as f64)?;
        crate::render::raycast::STEP.check_optional(self.step)?;
        crate::render::raycast::ERT_THRESHOLD.check(self.ert_threshold as f64)
    }
}

/// Directions of the transport solve. Light that has scattered is spread in angle by the phase
/// function at every bounce, and the solve keeps only its first two angular moments anyway,
/// so it needs far fewer directions than the ambient visibility's sharp shadows: on the
/// engine, the bonsai, the tooth and the CT phantom 16 and 32 give the same error against the
/// `multiple` reference (docs/transport.md), and 16 is twice as fast.
pub const TRANSPORT_DIRECTIONS: u32 = 16;

/// Fewest solver cells along the volume's longest axis. Multiply scattered light varies over
/// the medium's transport mean free path, many voxels in all but the densest matter, so the
/// solve may run on blocks of voxels; what sets how coarse is how finely the blocks still
/// resolve the body (its shell, its cavities) against the image: on 256-voxel volumes blocks
/// of 2^3 (128 cells) kept the error against the `multiple` reference, blocks of 4^3 (64
/// cells) doubled what the solve adds to it, and a 48^3 phantom on 24 cells was twice as far
/// as on its own grid (docs/transport.md).
pub const TRANSPORT_CELLS: usize = 128;

/// Voxels per solver cell along each axis for a volume of `dims`: the largest power of two
/// that leaves at least [`TRANSPORT_CELLS`] cells along the longest axis (1 for volumes of
/// fewer voxels than twice that).
pub fn transport_coarsen(dims: [usize; 3]) -> usize {
    let longest = dims.into_iter().max().unwrap_or(1);
    let mut f = 1;
    while longest / (2 * f) >= TRANSPORT_CELLS {
        f *= 2;
    }
    f
}

/// What IPSVI reads.
#[derive(Clone, Copy)]
pub struct IpsviInput<'a> {
    pub volume: &'a Volume,
    pub lut: &'a Lut,
    pub camera: &'a Camera,
    pub lighting: &'a Lighting,
    pub params: &'a IpsviParams,
}

impl IpsviInput<'_> {
    /// The cache's resolution: the size asked for, or [`Resolution::for_view`]'s default.
    pub fn resolution(&self) -> Resolution {
        Resolution::for_view(self.params.cache_size, self.volume, self.camera)
    }

    /// With `scattering = "transport"`, the medium of the solve (once for all lights).
    pub fn transport_medium(&self) -> Result<Option<crate::transport::medium::Medium>> {
        if self.params.scattering != Scattering::Transport {
            return Ok(None);
        }
        crate::transport::medium::Medium::classify(
            self.volume,
            self.lut,
            transport_coarsen(self.volume.dims()),
        )
        .map(Some)
    }

    /// The multiply scattered light of `light` in `medium`, 8 bounces as the `multiple`
    /// reference, solved on `gpu` (the CPU without one).
    pub fn transport_field(
        &self,
        gpu: Option<&crate::gpu::GpuContext>,
        medium: &crate::transport::medium::Medium,
        light: &Light,
        progress: &dyn Progress,
    ) -> Result<crate::transport::scattering::InScattered> {
        let params = crate::transport::scattering::ScatteringParams {
            directions: TRANSPORT_DIRECTIONS,
            bounces: crate::render::reference::DEFAULT_BOUNCES,
            g: self.params.g,
        };
        crate::transport::scattering::in_scattered(
            gpu,
            medium,
            light,
            &params,
            &crate::progress::Cancel(progress),
        )
    }

    /// Validates the inputs; returns the step. Lights other than directional and point lights
    /// are refused by name, as is a point light at the camera (its rays' images are undefined).
    pub fn setup(&self) -> Result<f32> {
        self.params.validate()?;
        self.lighting.validate()?;
        IpsviParams::SPEC.check_lights(self.lighting)?;
        for (i, light) in self.lighting.lights.iter().enumerate() {
            if let Light::Point { position, .. } = light {
                if (*position - self.camera.position).length()
                    <= 1e-6 * self.camera.position.length().max(1.0)
                {
                    return Err(Error::param(
                        format!("lights[{i}].position"),
                        "a point light at the camera's position has no image to sweep from; \
                         move it off the camera",
                    ));
                }
            }
        }
        let raycast = crate::render::raycast::RaycastParams {
            step: self.params.step,
            ..Default::default()
        };
        raycast.resolve_step(self.volume)
    }

    /// Each light's sweep, in the lighting's order (after `setup`, every light has one).
    fn sweeps(&self) -> Vec<Sweep<'_>> {
        let camera = self.camera;
        let (lo, hi) = self.volume.bounds();
        self.lighting
            .lights
            .iter()
            .filter_map(|light| {
                let shape = Shape::of(light, camera)?;
                let lines = Lines::new(shape, camera.width, camera.height, self.params.line_width);
                let map = CacheMap::new(light, lo, hi, self.resolution())?;
                Some(Sweep { light, lines, map })
            })
            .collect()
    }
}

/// One light's pass: the order of its lines and its cache's geometry.
struct Sweep<'a> {
    light: &'a Light,
    lines: Lines,
    map: CacheMap,
}

/// What one pixel gathers over every light's pass: the scattered light, and over the lights
/// the shadow layer's weights `W_l` (`irradiance`) and `W_l P_l` (`lit`) of the module docs;
/// emission, view transmittance and depth from the first pass (they are the same in every
/// pass).
#[derive(Clone, Copy, Debug)]
struct Gathered {
    scattered: Vec3,
    emitted: Vec3,
    transmittance: f32,
    depth: f32,
    lit: f32,
    irradiance: f32,
}

impl Default for Gathered {
    /// A pixel no pass reached: empty.
    fn default() -> Self {
        Self {
            scattered: Vec3::ZERO,
            emitted: Vec3::ZERO,
            transmittance: 1.0,
            depth: BACKGROUND_DEPTH,
            lit: 0.0,
            irradiance: 0.0,
        }
    }
}

/// The image (background behind what the view let through) and its `shadow` layer from what
/// every pixel gathered; the twins share it.
fn finish(camera: &Camera, background: Vec3, gathered: &[Gathered]) -> RenderImage {
    let mut image = RenderImage::new(camera.width, camera.height);
    for (p, g) in gathered.iter().enumerate() {
        let c = g.scattered + g.emitted + g.transmittance * background;
        image.rgba[p] = [c.x, c.y, c.z, 1.0 - g.transmittance];
        image.depth[p] = g.depth;
    }
    let coverage: Vec<f32> = image.rgba.iter().map(|p| p[3]).collect();
    let premultiplied: Vec<f32> = gathered
        .iter()
        .zip(&coverage)
        .map(|(g, &a)| {
            if g.irradiance > 0.0 {
                g.lit / g.irradiance
            } else {
                a
            }
        })
        .collect();
    image.factor = Some(Factor::new("shadow", &premultiplied, &coverage));
    image
}

/// Renders the image and its `shadow` layer on the chosen device.
pub fn render(
    compute: &crate::gpu::Compute,
    input: &IpsviInput,
    progress: &dyn Progress,
) -> Result<RenderImage> {
    match compute {
        crate::gpu::Compute::Cpu => cpu::render(input, progress),
        crate::gpu::Compute::Gpu(ctx) => gpu::render(ctx, input, progress),
    }
}
