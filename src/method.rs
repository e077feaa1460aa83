//! The method contract: what every rendering method declares ([`MethodSpec`]: its parameters
//! with their ranges and documentation, the lights it accepts, the layers and grids it writes)
//! and implements ([`RenderMethod`]). It sits below the methods, which implement it, and below
//! the registry (`crate::registry`), which lists them; so a method never imports the list.

use crate::error::{Error, Result};
use crate::lights::{LightKind, Lighting};
use crate::render::{MethodInput, Rendered};
use serde::de::DeserializeOwned;
use serde::Serialize;
use std::fmt::Debug;

/// What a method is, for every consumer of the registry.
#[derive(Debug, Serialize)]
pub struct MethodSpec {
    /// The name a scene's `[render] method` gives.
    pub name: &'static str,
    /// One line for menus and help.
    pub summary: &'static str,
    /// Where its code lives, under src/.
    pub module: &'static str,
    /// Its WGSL kernels (beside its GPU code, or the GPU code it runs on).
    pub shaders: &'static [&'static str],
    /// The lights it renders; a scene with others is refused.
    pub lights: &'static [LightKind],
    /// The layers of the EXR it writes.
    pub layers: &'static [&'static str],
    /// The VDB grids `export` writes for it beyond `density` and `value`.
    pub grids: &'static [&'static str],
    /// The settings `occlux chart` measures it at: `[render]` keys as TOML ("" for the
    /// defaults), its speed-accuracy trade-offs worth seeing beside the other methods'.
    pub chart: &'static [&'static str],
    /// The lights its model is for: the chart, the planner and the gallery weigh it only in
    /// scenes with one of them ([`MethodSpec::weighs`]). AO-shaded DVR renders suns too, but
    /// only by gradient shading: under suns alone every one of its settings is gradient DVR at
    /// a higher cost.
    pub for_lights: &'static [LightKind],
    pub params: &'static [ParamSpec],
}

/// Every kind of light.
pub const ALL_LIGHTS: &[LightKind] =
    &[LightKind::Ambient, LightKind::Directional, LightKind::Point];

/// One parameter of a method: its key in `[render]`, what it means and what it accepts.
#[derive(Debug, Serialize)]
pub struct ParamSpec {
    pub key: &'static str,
    pub doc: &'static str,
    #[serde(flatten)]
    pub kind: ParamKind,
}

/// What values a parameter takes.
#[derive(Debug, Serialize)]
#[serde(tag = "type", rename_all = "lowercase")]
pub enum ParamKind {
    /// A real number in `range`; `optional`: it may be left out, and `doc` says what is used then.
    Float {
        range: Range,
        optional: bool,
    },
    /// A whole number in `range` (inclusive bounds); `optional` as for `Float`.
    Int {
        range: Range,
        optional: bool,
    },
    Bool,
    /// One of the named options.
    Choice {
        options: &'static [Choice],
    },
    /// A list of at most `max` clipping planes, each `{ point, normal }`.
    Planes {
        max: usize,
    },
}

/// One option of a [`ParamKind::Choice`].
#[derive(Debug, Serialize)]
pub struct Choice {
    pub name: &'static str,
    pub doc: &'static str,
}

/// An interval; an infinite bound is written as null in JSON.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct Range {
    pub min: f64,
    pub max: f64,
    pub min_inclusive: bool,
    pub max_inclusive: bool,
}

impl Range {
    /// [min, max].
    pub const fn closed(min: f64, max: f64) -> Self {
        Self {
            min,
            max,
            min_inclusive: true,
            max_inclusive: true,
        }
    }

    /// [min, max).
    pub const fn below(min: f64, max: f64) -> Self {
        Self {
            max_inclusive: false,
            ..Self::closed(min, max)
        }
    }

    /// (min, max].
    pub const fn above(min: f64, max: f64) -> Self {
        Self {
            min_inclusive: false,
            ..Self::closed(min, max)
        }
    }

    /// (0, infinity): lengths.
    pub const POSITIVE: Range = Range {
        min: 0.0,
        max: f64::INFINITY,
        min_inclusive: false,
        max_inclusive: false,
    };

    /// Any finite number: values in the data's own units.
    pub const FINITE: Range = Range {
        min: f64::NEG_INFINITY,
        max: f64::INFINITY,
        min_inclusive: false,
        max_inclusive: false,
    };

    pub fn contains(&self, v: f64) -> bool {
        let above = if self.min_inclusive {
            v >= self.min
        } else {
            v > self.min
        };
        let below = if self.max_inclusive {
            v <= self.max
        } else {
            v < self.max
        };
        above && below
    }
}

impl std::fmt::Display for Range {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{}{}, {}{}",
            if self.min_inclusive { "[" } else { "(" },
            self.min,
            self.max,
            if self.max_inclusive { "]" } else { ")" }
        )
    }
}

impl MethodSpec {
    /// Whether the method is worth weighing for `lighting`: a scene lit by emission alone, or
    /// one with a light of [`MethodSpec::for_lights`].
    pub fn weighs(&self, lighting: &Lighting) -> bool {
        lighting.lights.is_empty()
            || lighting
                .lights
                .iter()
                .any(|l| self.for_lights.contains(&l.kind()))
    }

    /// The lights of `lighting` that the method renders (the background kept).
    pub fn lights_of(&self, lighting: &Lighting) -> Lighting {
        Lighting {
            lights: lighting
                .lights
                .iter()
                .filter(|l| self.lights.contains(&l.kind()))
                .copied()
                .collect(),
            background: lighting.background,
        }
    }

    /// Refuses lights the method does not render, naming the first such light.
    pub fn check_lights(&self, lighting: &Lighting) -> Result<()> {
        match lighting
            .lights
            .iter()
            .position(|l| !self.lights.contains(&l.kind()))
        {
            None => Ok(()),
            Some(i) => {
                let kinds: Vec<&str> = self.lights.iter().map(|k| k.name()).collect();
                Err(Error::param(
                    format!("lights[{i}]"),
                    format!(
                        "is {}, but method \"{}\" is lit by {} lights only; remove the others",
                        lighting.lights[i].kind().name(),
                        self.name,
                        kinds.join(", ")
                    ),
                ))
            }
        }
    }
}

impl ParamSpec {
    /// `value` checked against the parameter's range; the error names `render.KEY`.
    pub fn check(&self, value: f64) -> Result<()> {
        let range = match &self.kind {
            ParamKind::Float { range, .. } | ParamKind::Int { range, .. } => range,
            _ => return Ok(()),
        };
        if range.contains(value) {
            Ok(())
        } else {
            Err(self.error(format!("must be in {range}, got {value}")))
        }
    }

    /// As [`ParamSpec::check`] for an optional value; absent is fine.
    pub fn check_optional(&self, value: Option<f32>) -> Result<()> {
        value.map_or(Ok(()), |v| self.check(v as f64))
    }

    /// An error about this parameter, naming `render.KEY`.
    pub fn error(&self, message: impl Into<String>) -> Error {
        Error::param(format!("render.{}", self.key), message)
    }
}

/// A rendering method's parameters: a struct whose fields are the method's keys in `[render]`
/// (serde, unknown keys refused), checked against its [`MethodSpec`].
pub trait RenderMethod: Clone + Debug + PartialEq + Default + Serialize + DeserializeOwned {
    const SPEC: MethodSpec;

    /// Checks every parameter against the spec's ranges and their relations, and brings them to
    /// the form the renderer reads (unit normals).
    fn resolve(self) -> Result<Self>;

    fn render(&self, input: &MethodInput) -> Result<Rendered>;

    /// The grids [`RenderMethod::render`] computes with these parameters, in its order: the
    /// ones of the spec's `grids` that these settings produce.
    fn grids(&self) -> Vec<&'static str> {
        Vec::new()
    }

    /// The path-traced model these settings approximate, where one exists: its Monte Carlo
    /// estimator and phase asymmetry g. `occlux chart` measures a method against it beside the
    /// physical truth of the scene, to tell the method's own error from its model's. None for
    /// shading heuristics with no such model (gradient shading, the unoccluded ambient term).
    fn model(&self) -> Option<Model> {
        None
    }

    /// Peak memory of a render (or export) with these parameters, as a multiple of the dense
    /// f32 volume: the volume and what the renderer keeps per voxel besides. The loaders refuse
    /// a volume whose peak would not fit ([`crate::memory::MemoryBudget`]).
    fn peak_volumes(&self) -> f64 {
        RENDER_PEAK_VOLUMES
    }
}

/// The peak of a render that keeps no grid of its own beside the volume: the volume and the
/// occupancy and majorant grids, a small fraction of it (`bench/memory.sh`: 1.18x at 512^3
/// with a 1024^2 image, 0.15x of which is the image, counted apart by
/// [`crate::scene::IMAGE_BYTES_PER_PIXEL`]).
pub const RENDER_PEAK_VOLUMES: f64 = 1.1;

/// A path-traced model a method approximates (see [`RenderMethod::model`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Model {
    pub estimator: crate::render::reference::Estimator,
    pub g: f32,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ranges_print_and_hold_their_bounds() {
        let r = Range::below(0.0, 90.0);
        assert_eq!(r.to_string(), "[0, 90)");
        assert!(r.contains(0.0) && r.contains(89.99) && !r.contains(90.0));
        assert!(!Range::POSITIVE.contains(0.0) && Range::POSITIVE.contains(1e-30));
        assert!(!Range::POSITIVE.contains(f64::NAN) && !Range::POSITIVE.contains(f64::INFINITY));
    }
}
