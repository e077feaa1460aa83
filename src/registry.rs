//! The method registry: every rendering method a scene can name, with its parameters (defaults,
//! ranges, documentation), the lights it accepts and the EXR layers and VDB grids it writes.
//! The scene parser, the CLI (`occlux methods`), the benchmarks and accuracy tables, the Python
//! package (`occlux.methods()`) and the Blender add-on (its property limits) all read it, so
//! none of them repeats what a method is.
//!
//! A method is one folder under `src/render/` (its parameters, CPU twin, GPU twin and a
//! [`RenderMethod`] impl of the contract in [`crate::method`]) with its kernels in `NAME*.wgsl`
//! beside its GPU code, and one line in the `methods!` list at the bottom of this file.

use crate::error::{Error, Result};
use crate::lights::LightKind;
use crate::method::{MethodSpec, Model, ParamKind, RenderMethod};
use crate::render::{MethodInput, Rendered};
use serde::{Deserialize, Serialize};
use serde_json::{Map, Value};
use std::fmt::Debug;

/// The registered method behind a spec, at one of its settings.
impl MethodSpec {
    /// The method at one of its settings for `occlux chart` (`[render]` keys as TOML).
    pub fn at_setting(&self, setting: &str) -> Result<Method> {
        let mut table: Map<String, Value> = toml::from_str(setting).map_err(|e| {
            Error::param(
                format!("{}.chart", self.name),
                format!("'{setting}': {}", e.message()),
            )
        })?;
        table.insert("method".to_owned(), Value::String(self.name.to_owned()));
        Method::from_table(table)
    }
}

/// The method a scene renders with when its `[render]` names none.
pub const DEFAULT_METHOD: &str = "gradient";

/// The registered method called `name`.
pub fn find(name: &str) -> Option<&'static MethodSpec> {
    METHODS.iter().copied().find(|m| m.name == name)
}

/// The registry as JSON: each method's spec with each parameter's default (from the
/// parameters' `Default`) beside its range.
pub fn describe() -> Value {
    Value::Array(
        METHODS
            .iter()
            .zip(defaults())
            .map(|(spec, defaults)| {
                let mut entry = crate::json::tree(spec);
                if let Some(params) = entry.get_mut("params").and_then(Value::as_array_mut) {
                    for param in params {
                        let key = param["key"].as_str().unwrap_or_default().to_owned();
                        param["default"] = defaults.get(&key).cloned().unwrap_or(Value::Null);
                    }
                }
                entry
            })
            .collect(),
    )
}

/// The registry as text for people: per method its summary, lights, layers and grids, and per
/// parameter its default, what it accepts and what it means.
pub fn summary() -> String {
    let mut text = String::new();
    for (spec, defaults) in METHODS.iter().zip(defaults()) {
        let names = |kinds: &[LightKind]| -> String {
            let names: Vec<&str> = kinds.iter().map(|l| l.name()).collect();
            names.join(", ")
        };
        let grids = if spec.grids.is_empty() {
            "-".to_owned()
        } else {
            spec.grids.join(", ")
        };
        text += &format!("{}: {}\n", spec.name, spec.summary);
        text += &format!(
            "  lights {} (made for {}); layers {}; grids {grids}\n",
            names(spec.lights),
            names(spec.for_lights),
            spec.layers.join(", ")
        );
        for param in spec.params {
            let default = match defaults.get(param.key) {
                None | Some(Value::Null) => "-".to_owned(),
                Some(value) => value.to_string(),
            };
            let accepts = match &param.kind {
                ParamKind::Float { range, .. } | ParamKind::Int { range, .. } => range.to_string(),
                ParamKind::Bool => "true, false".to_owned(),
                ParamKind::Choice { options } => options
                    .iter()
                    .map(|o| o.name)
                    .collect::<Vec<_>>()
                    .join(", "),
                ParamKind::Planes { max } => format!("at most {max} planes"),
            };
            text += &format!(
                "  {:<19} {:<10} {:<22} {}\n",
                param.key, default, accepts, param.doc
            );
        }
    }
    text
}

impl Method {
    /// The method of a scene's `[render]` table: `method` picks the registered method (default
    /// [`DEFAULT_METHOD`]), the other keys are its parameters. Errors name `render.KEY`.
    pub fn from_table(mut table: Map<String, Value>) -> Result<Method> {
        let name = match table.remove("method") {
            None => DEFAULT_METHOD.to_owned(),
            Some(Value::String(name)) => name,
            Some(other) => {
                return Err(Error::param(
                    "render.method",
                    format!("must be a method name, got {other}"),
                ))
            }
        };
        let spec = find(&name).ok_or_else(|| {
            Error::param(
                "render.method",
                format!("unknown method '{name}'; known: {}", names().join(", ")),
            )
        })?;
        if let Some(key) = table
            .keys()
            .find(|key| !spec.params.iter().any(|p| p.key == key.as_str()))
        {
            return Err(foreign_key(spec, key));
        }
        Self::parse_params(spec.name, Value::Object(table))
    }

    /// The method's registry entry.
    pub fn spec(&self) -> &'static MethodSpec {
        Self::spec_of(self)
    }

    /// The parameters as JSON, `method` naming the method (the EXR header's `occlux/method`).
    pub fn to_json(&self) -> Value {
        crate::json::tree(self)
    }

    /// The ray-marching step the scene set (`render.step`, the same key and meaning in every
    /// method that takes one), None when it is left to its default or the method has none.
    pub fn step(&self) -> Option<f32> {
        self.to_json()
            .get("step")
            .and_then(Value::as_f64)
            .map(|step| step as f32)
    }
}

/// The registered method names.
pub fn names() -> Vec<&'static str> {
    METHODS.iter().map(|m| m.name).collect()
}

/// The error for a key that `spec` does not take: which methods do, or what it takes.
fn foreign_key(spec: &MethodSpec, key: &str) -> Error {
    let owners: Vec<String> = METHODS
        .iter()
        .filter(|m| m.params.iter().any(|p| p.key == key))
        .map(|m| format!("\"{}\"", m.name))
        .collect();
    let message = if owners.is_empty() {
        let keys: Vec<&str> = spec.params.iter().map(|p| p.key).collect();
        format!(
            "not a parameter of method = \"{}\" (it takes: {})",
            spec.name,
            keys.join(", ")
        )
    } else {
        format!(
            "only for method = {} (not \"{}\")",
            owners.join(" or "),
            spec.name
        )
    };
    Error::param(format!("render.{key}"), message)
}

/// Deserializes and resolves one method's parameters; errors name `render.KEY`.
fn parse<P: RenderMethod>(value: Value) -> Result<P> {
    let params: P = serde_path_to_error::deserialize(value).map_err(|e| {
        let path = e.path().to_string();
        let key = if path == "." {
            "render".to_owned()
        } else {
            format!("render.{path}")
        };
        Error::param(key, e.inner().to_string())
    })?;
    params.resolve()
}

/// Declares the registered methods: the [`Method`] enum (serde, internally tagged by `method`),
/// [`METHODS`], and the dispatch from a method to its parameters' [`RenderMethod`] impl.
macro_rules! methods {
    ($($variant:ident => $params:ty),* $(,)?) => {
        /// A scene's rendering method with its parameters.
        #[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
        #[serde(tag = "method", rename_all = "kebab-case")]
        pub enum Method {
            $($variant($params),)*
        }

        /// Every registered method, in menu order.
        pub const METHODS: &[&MethodSpec] = &[$(&<$params as RenderMethod>::SPEC,)*];

        /// Each method's default parameters as JSON, in the order of [`METHODS`].
        fn defaults() -> Vec<Map<String, Value>> {
            let as_map = |v: Value| match v {
                Value::Object(map) => map,
                _ => Map::new(),
            };
            vec![$(as_map(crate::json::tree(&<$params>::default())),)*]
        }

        impl Method {
            fn parse_params(name: &str, value: Value) -> Result<Method> {
                $(if name == <$params as RenderMethod>::SPEC.name {
                    return parse::<$params>(value).map(Method::$variant);
                })*
                Err(Error::param("render.method", format!("unknown method '{name}'")))
            }

            fn spec_of(&self) -> &'static MethodSpec {
                match self {
                    $(Method::$variant(_) => &<$params as RenderMethod>::SPEC,)*
                }
            }

            /// The grids a render computes with these parameters.
            pub fn grids(&self) -> Vec<&'static str> {
                match self {
                    $(Method::$variant(params) => params.grids(),)*
                }
            }

            /// The path-traced model these settings approximate ([`RenderMethod::model`]).
            pub fn model(&self) -> Option<Model> {
                match self {
                    $(Method::$variant(params) => params.model(),)*
                }
            }

            /// Peak memory of a render as a multiple of the dense f32 volume
            /// ([`RenderMethod::peak_volumes`]).
            pub fn peak_volumes(&self) -> f64 {
                match self {
                    $(Method::$variant(params) => params.peak_volumes(),)*
                }
            }

            /// Renders the method for an already loaded volume.
            pub fn render(&self, input: &MethodInput) -> Result<Rendered> {
                match self {
                    $(Method::$variant(params) => params.render(input),)*
                }
            }
        }
    };
}

methods! {
    Unshaded => crate::render::raycast::UnshadedParams,
    Gradient => crate::render::raycast::GradientParams,
    Ao => crate::render::ao_shaded::AoParams,
    Dos => crate::render::dos::DosParams,
    Ipsvi => crate::render::ipsvi::IpsviParams,
    HalfAngle => crate::render::half_angle::HalfAngleParams,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_method_has_chart_settings_it_takes() {
        for spec in METHODS {
            assert!(!spec.chart.is_empty(), "{}", spec.name);
            for setting in spec.chart {
                let method = spec.at_setting(setting).unwrap();
                assert_eq!(method.spec().name, spec.name, "{setting}");
            }
        }
        let dos = find("dos").unwrap();
        assert!(dos.at_setting("theta_deg = 95").is_err());
        assert!(dos.at_setting("theta_deg = ").is_err());
    }

    #[test]
    fn foreign_keys_name_their_methods() {
        let gradient = find("gradient").unwrap();
        let msg = foreign_key(gradient, "theta_deg").to_string();
        assert!(
            msg.contains("render.theta_deg") && msg.contains("\"dos\""),
            "{msg}"
        );
        let msg = foreign_key(gradient, "colour").to_string();
        assert!(msg.contains("it takes: step, ert_threshold"), "{msg}");
    }
}
