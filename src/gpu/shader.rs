//! WGSL sources, `//#include "name.wgsl"` expansion, and cached compute pipelines (creating one
//! JIT-compiles the shader, 60-800 ms on lavapipe, so each is built once per context). Each method
//! embeds its own kernels beside its GPU code as a [`Wgsl`] (`include_str!`); the helpers any
//! kernel may include are the shared ones of shaders/shared/ ([`SHARED`]), so a new method adds
//! files of its own and touches nothing here. A caller's text (a test's kernel) may include the
//! shared helpers too.

use std::collections::{HashMap, HashSet};
use std::sync::Mutex;

use crate::error::{Error, Result};

use super::context::GpuContext;

/// A WGSL file, embedded by the module that owns it: its name (in errors, in the pipeline cache
/// and in `//#include` lines), its text, and the owner's other files it includes.
#[derive(Debug)]
pub struct Wgsl {
    pub name: &'static str,
    pub text: &'static str,
    /// The owner's files this one includes (and, through them, theirs); the shared helpers need
    /// no listing.
    pub includes: &'static [&'static Wgsl],
}

/// Small helpers (the volume's sampling, ray-box clipping).
pub const COMMON: Wgsl = Wgsl {
    name: "common.wgsl",
    text: include_str!("../../shaders/shared/common.wgsl"),
    includes: &[],
};
/// The classification table's lookup (`LutShape`) and the emission integral.
pub const CLASSIFY: Wgsl = Wgsl {
    name: "classify.wgsl",
    text: include_str!("../../shaders/shared/classify.wgsl"),
    includes: &[],
};
/// Empty-space skipping over the occupancy grid.
pub const OCCUPANCY: Wgsl = Wgsl {
    name: "occupancy.wgsl",
    text: include_str!("../../shaders/shared/occupancy.wgsl"),
    includes: &[],
};
/// The camera (`View`) and the rays it casts.
pub const VIEW: Wgsl = Wgsl {
    name: "view.wgsl",
    text: include_str!("../../shaders/shared/view.wgsl"),
    includes: &[],
};
/// The voxel an invocation of an anti-diagonal plane's dispatch stands for (plane-by-plane
/// sweeps).
pub const PLANE: Wgsl = Wgsl {
    name: "plane.wgsl",
    text: include_str!("../../shaders/shared/plane.wgsl"),
    includes: &[],
};
/// The Henyey-Greenstein phase and the basis of its bands (transport::scattering::bands).
pub const PHASE: Wgsl = Wgsl {
    name: "phase.wgsl",
    text: include_str!("../../shaders/shared/phase.wgsl"),
    includes: &[],
};
/// The planes and slots of the discrete-ordinates sweeps (transport::gpu::sweep_orders).
pub const ORDINATES: Wgsl = Wgsl {
    name: "ordinates.wgsl",
    text: include_str!("../../shaders/shared/ordinates.wgsl"),
    includes: &[],
};
/// The helpers any kernel may include.
pub const SHARED: &[&Wgsl] = &[
    &COMMON, &CLASSIFY, &OCCUPANCY, &VIEW, &PLANE, &PHASE, &ORDINATES,
];

const INCLUDE: &str = "//#include";

/// The text of `shader` with its includes expanded. Each file is included at most once (later
/// includes of it, and include cycles, expand to nothing).
pub fn source(shader: &Wgsl) -> Result<String> {
    let mut out = String::new();
    let lookup = |name: &str| find(shader, name);
    expand(shader.name, &lookup, &mut HashSet::new(), &mut out)?;
    Ok(out)
}

/// `text` (named `label` in errors) with its includes of the shared helpers expanded, as
/// [`source`].
fn expand_text(label: &str, text: &str) -> Result<String> {
    let mut out = String::new();
    let lookup = |name: &str| find_shared(name, &[]);
    expand_lines(label, text, &lookup, &mut HashSet::new(), &mut out)?;
    Ok(out)
}

/// The text of the file `name` as `shader` sees it: itself, one of its includes (at any depth)
/// or a shared helper.
fn find(shader: &Wgsl, name: &str) -> Result<&'static str> {
    let mut owned = vec![];
    let mut todo = vec![shader];
    while let Some(file) = todo.pop() {
        if file.name == name {
            return Ok(file.text);
        }
        owned.push(file.name);
        todo.extend(file.includes.iter().copied());
    }
    find_shared(name, &owned)
}

/// A shared helper's text; the error lists `owned` (the includer's own files) and the helpers.
fn find_shared(name: &str, owned: &[&str]) -> Result<&'static str> {
    SHARED
        .iter()
        .find(|file| file.name == name)
        .map(|file| file.text)
        .ok_or_else(|| {
            let known: Vec<&str> = owned
                .iter()
                .copied()
                .chain(SHARED.iter().map(|file| file.name))
                .collect();
            Error::Gpu(format!(
                "no shader named \"{name}\" (known: {})",
                known.join(", ")
            ))
        })
}

/// Appends `name`, with its includes expanded, to `out`; `lookup` gives a file's raw text.
fn expand<'a>(
    name: &str,
    lookup: &dyn Fn(&str) -> Result<&'a str>,
    included: &mut HashSet<String>,
    out: &mut String,
) -> Result<()> {
    if !included.insert(name.to_owned()) {
        return Ok(());
    }
    expand_lines(name, lookup(name)?, lookup, included, out)
}

/// Appends the lines of `text` (file `name`) to `out`, each include replaced by its expansion.
fn expand_lines<'a>(
    name: &str,
    text: &str,
    lookup: &dyn Fn(&str) -> Result<&'a str>,
    included: &mut HashSet<String>,
    out: &mut String,
) -> Result<()> {
    for (number, line) in text.lines().enumerate() {
        match line.trim().strip_prefix(INCLUDE) {
            Some(rest) => {
                let target = parse_include(rest).ok_or_else(|| {
                    Error::Gpu(format!(
                        "{name}:{}: expected {INCLUDE} \"file.wgsl\", got `{}`",
                        number + 1,
                        line.trim()
                    ))
                })?;
                expand(target, lookup, included, out)
                    .map_err(|e| Error::Gpu(format!("{name}:{}: {e}", number + 1)))?;
            }
            None => {
                out.push_str(line);
                out.push('\n');
            }
        }
    }
    Ok(())
}

/// The quoted file name after `//#include`.
fn parse_include(rest: &str) -> Option<&str> {
    rest.trim()
        .strip_prefix('"')?
        .strip_suffix('"')
        .filter(|name| !name.is_empty())
}

/// What a cached pipeline was compiled from.
#[derive(Debug, Clone, PartialEq, Eq, Hash)]
enum Shader {
    /// A [`Wgsl`] file, by name.
    File(String),
    /// A caller's text, whole (two texts under one label must not share a pipeline).
    Text(String),
}

/// Compute pipelines of one context, keyed by (shader, entry point).
#[derive(Debug, Default)]
pub(super) struct PipelineCache(Mutex<HashMap<(Shader, String), wgpu::ComputePipeline>>);

/// The compute pipeline for `entry_point` of `shader`, built on first use with the bind
/// group layouts that wgpu derives from the shader (`layout: None`), then cached in `ctx`.
/// A shader that does not compile is an `Error::Gpu` with naga's message.
pub fn compute_pipeline(
    ctx: &GpuContext,
    shader: &Wgsl,
    entry_point: &str,
) -> Result<wgpu::ComputePipeline> {
    cached_pipeline(
        ctx,
        Shader::File(shader.name.to_owned()),
        shader.name,
        entry_point,
        || source(shader),
    )
}

/// As [`compute_pipeline`] for a caller's text (a test's kernel), whose `//#include` lines name
/// shared helpers ([`SHARED`]); `label` names it in errors.
pub fn compute_pipeline_from_text(
    ctx: &GpuContext,
    label: &str,
    text: &str,
    entry_point: &str,
) -> Result<wgpu::ComputePipeline> {
    cached_pipeline(
        ctx,
        Shader::Text(text.to_owned()),
        label,
        entry_point,
        || expand_text(label, text),
    )
}

/// The pipeline cached under `shader`, else built from the text that `expanded` gives (named
/// `label` in errors) and cached.
fn cached_pipeline(
    ctx: &GpuContext,
    shader: Shader,
    label: &str,
    entry_point: &str,
    expanded: impl FnOnce() -> Result<String>,
) -> Result<wgpu::ComputePipeline> {
    let key = (shader, entry_point.to_owned());
    if let Some(pipeline) = lock(&ctx.pipelines)?.get(&key) {
        return Ok(pipeline.clone());
    }
    // Built outside the lock: compiling is slow and other pipelines need not wait for it.
    let pipeline = build_pipeline(ctx, label, expanded()?, entry_point)?;
    lock(&ctx.pipelines)?.insert(key, pipeline.clone());
    Ok(pipeline)
}

fn lock(
    cache: &PipelineCache,
) -> Result<std::sync::MutexGuard<'_, HashMap<(Shader, String), wgpu::ComputePipeline>>> {
    cache
        .0
        .lock()
        .map_err(|_| Error::Gpu("pipeline cache poisoned by an earlier panic".into()))
}

/// Compiles `text` (expanded) and builds the pipeline of its `entry_point`.
fn build_pipeline(
    ctx: &GpuContext,
    name: &str,
    text: String,
    entry_point: &str,
) -> Result<wgpu::ComputePipeline> {
    ctx.checked(&format!("shader {name}, entry point {entry_point}"), || {
        let module = ctx
            .device
            .create_shader_module(wgpu::ShaderModuleDescriptor {
                label: Some(name),
                source: wgpu::ShaderSource::Wgsl(text.into()),
            });
        ctx.device
            .create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                label: Some(name),
                layout: None,
                module: &module,
                entry_point: Some(entry_point),
                compilation_options: Default::default(),
                cache: None,
            })
    })
}

/// A bind group for group 0 of `pipeline`, binding `resources[i]` at `@binding(i)`.
pub fn bind_group(
    ctx: &GpuContext,
    pipeline: &wgpu::ComputePipeline,
    resources: &[wgpu::BindingResource<'_>],
) -> Result<wgpu::BindGroup> {
    let numbered: Vec<(u32, wgpu::BindingResource<'_>)> = resources
        .iter()
        .enumerate()
        .map(|(binding, resource)| (binding as u32, resource.clone()))
        .collect();
    bind_group_at(ctx, pipeline, &numbered)
}

/// A bind group for group 0 of `pipeline`, binding each `(binding, resource)`: for an entry
/// point of a shader with several, whose bindings are not numbered from 0 without gaps.
pub fn bind_group_at(
    ctx: &GpuContext,
    pipeline: &wgpu::ComputePipeline,
    resources: &[(u32, wgpu::BindingResource<'_>)],
) -> Result<wgpu::BindGroup> {
    let entries: Vec<wgpu::BindGroupEntry<'_>> = resources
        .iter()
        .map(|(binding, resource)| wgpu::BindGroupEntry {
            binding: *binding,
            resource: resource.clone(),
        })
        .collect();
    ctx.checked("bind group", || {
        ctx.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: None,
            layout: &pipeline.get_bind_group_layout(0),
            entries: &entries,
        })
    })
}

/// Records and submits one dispatch of `workgroups` (does not wait for it).
pub fn dispatch(
    ctx: &GpuContext,
    pipeline: &wgpu::ComputePipeline,
    bind_group: &wgpu::BindGroup,
    workgroups: [u32; 3],
) -> Result<()> {
    let max = ctx.limits.max_compute_workgroups_per_dimension;
    if workgroups.iter().any(|&n| n > max) {
        return Err(Error::Gpu(format!(
            "dispatch of {workgroups:?} workgroups is over the adapter's {max} per dimension"
        )));
    }
    ctx.checked("dispatch", || {
        let mut encoder = ctx.device.create_command_encoder(&Default::default());
        {
            let mut pass = encoder.begin_compute_pass(&Default::default());
            pass.set_pipeline(pipeline);
            pass.set_bind_group(0, bind_group, &[]);
            pass.dispatch_workgroups(workgroups[0], workgroups[1], workgroups[2]);
        }
        ctx.queue.submit([encoder.finish()]);
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn includes_expand_once_in_place() {
        const KERNEL: Wgsl = Wgsl {
            name: "kernel.wgsl",
            text:
                "//#include \"view.wgsl\"\n//#include \"local.wgsl\"\n//#include \"common.wgsl\"\n\
                   fn main() {}\n",
            includes: &[&LOCAL],
        };
        const LOCAL: Wgsl = Wgsl {
            name: "local.wgsl",
            text: "//#include \"common.wgsl\"\nfn local() {}\n",
            includes: &[],
        };
        let text = source(&KERNEL).unwrap();
        assert!(
            !text.lines().any(|l| l.trim().starts_with(INCLUDE)),
            "{text}"
        );
        assert_eq!(text.matches("fn sample_volume(").count(), 1);
        assert_eq!(text.matches("struct View {").count(), 1);
        assert_eq!(text.matches("fn local(").count(), 1);
        // The include stands where its directive stood: before the kernel that uses it.
        assert!(text.find("struct View {").unwrap() < text.find("fn local(").unwrap());
        assert!(text.find("fn sample_volume(").unwrap() < text.find("fn local(").unwrap());
        assert!(text.find("fn local(").unwrap() < text.find("fn main(").unwrap());
    }

    #[test]
    fn a_callers_text_includes_the_shaders() {
        let text =
            "// kernel\n//#include \"common.wgsl\"\n//#include \"common.wgsl\"\nfn main() {}\n";
        let expanded = expand_text("kernel.wgsl", text).unwrap();
        assert!(expanded.starts_with("// kernel\n"), "{expanded}");
        assert_eq!(expanded.matches("fn sample_volume(").count(), 1);
        assert!(expanded.ends_with("fn main() {}\n"), "{expanded}");
        let err = expand_text("kernel.wgsl", "//#include \"nope.wgsl\"")
            .unwrap_err()
            .to_string();
        assert!(
            err.contains("kernel.wgsl:1") && err.contains("nope.wgsl"),
            "{err}"
        );
    }

    #[test]
    fn double_and_cyclic_includes_expand_once() {
        let files = [
            ("a", "//#include \"b\"\n  //#include \"c\"\nA"),
            ("b", "//#include \"c\"\nB"),
            ("c", "//#include \"a\"\nC"),
        ];
        let lookup = |name: &str| -> Result<&'static str> {
            files
                .iter()
                .find(|(n, _)| *n == name)
                .map(|(_, t)| *t)
                .ok_or_else(|| Error::Gpu(name.into()))
        };
        let mut out = String::new();
        expand("a", &lookup, &mut HashSet::new(), &mut out).unwrap();
        assert_eq!(out, "C\nB\nA\n");
    }

    #[test]
    fn unknown_and_malformed_includes_are_errors() {
        const LONE: Wgsl = Wgsl {
            name: "lone.wgsl",
            text: "//#include \"nope.wgsl\"\n",
            includes: &[],
        };
        let err = source(&LONE).unwrap_err().to_string();
        assert!(err.contains("no shader named \"nope.wgsl\"") && err.contains("common.wgsl"));
        assert!(err.starts_with("GPU: lone.wgsl:1: "), "{err}");
        assert_eq!(parse_include(" \"a.wgsl\" "), Some("a.wgsl"));
        assert_eq!(parse_include(" a.wgsl"), None);
        assert_eq!(parse_include(" \"\""), None);
    }
}
