//! Test support: the layout naga gives the structs of a shader, to hold the `#[repr(C)]`
//! mirrors of uniforms to it. A mirror that drifts from its WGSL struct feeds the kernel wrong
//! values without any error, so each mirror has a test built on [`assert_mirrors!`].

use wgpu::naga;

use super::shader::{self, Wgsl};

/// `shader` with its includes, parsed and validated by naga as wgpu does (validation enforces
/// WGSL's uniform layout rules, such as 16-byte array strides).
fn module(shader: &Wgsl) -> naga::Module {
    let name = shader.name;
    let text = shader::source(shader).unwrap();
    let module = naga::front::wgsl::parse_str(&text)
        .unwrap_or_else(|e| panic!("{name}: {}", e.emit_to_string(&text)));
    naga::valid::Validator::new(
        naga::valid::ValidationFlags::all(),
        naga::valid::Capabilities::default(),
    )
    .validate(&module)
    .unwrap_or_else(|e| panic!("{name}: {}", e.emit_to_string(&text)));
    module
}

/// Checks that a Rust struct of `size` bytes with fields at `offsets` (name, offset) mirrors
/// struct `wgsl_struct` of `shader`: same size, every WGSL member but padding (`_` names) listed,
/// each at its WGSL offset.
pub(crate) fn check_mirror(
    shader: &Wgsl,
    wgsl_struct: &str,
    size: usize,
    offsets: &[(&str, usize)],
) {
    let module = module(shader);
    let what = format!("{wgsl_struct} of {}", shader.name);
    let (members, span) = module
        .types
        .iter()
        .find_map(|(_, ty)| match &ty.inner {
            naga::TypeInner::Struct { members, span }
                if ty.name.as_deref() == Some(wgsl_struct) =>
            {
                Some((members, *span))
            }
            _ => None,
        })
        .unwrap_or_else(|| panic!("no struct {what}"));
    assert_eq!(size, span as usize, "size of {what}'s mirror");
    let wgsl: Vec<(&str, usize)> = members
        .iter()
        .filter_map(|m| Some((m.name.as_deref()?, m.offset as usize)))
        .filter(|(name, _)| !name.starts_with('_'))
        .collect();
    let mut listed: Vec<(&str, usize)> = offsets.to_vec();
    listed.sort_by_key(|&(_, offset)| offset);
    assert_eq!(listed, wgsl, "fields (name, offset) of {what}'s mirror");
}

/// The value of `const name: u32` in `shader`.
pub(crate) fn u32_constant(shader: &Wgsl, name: &str) -> u32 {
    let module = module(shader);
    let init = module
        .constants
        .iter()
        .find(|(_, c)| c.name.as_deref() == Some(name))
        .unwrap_or_else(|| panic!("no const {name} in {}", shader.name))
        .1
        .init;
    match module.global_expressions[init] {
        naga::Expression::Literal(naga::Literal::U32(value)) => value,
        ref other => panic!(
            "const {name} of {} is {other:?}, not a u32 literal",
            shader.name
        ),
    }
}

/// `assert_mirrors!(RustType, SHADER, "WgslStruct", [field, ...])`: the Rust type has
/// the WGSL struct's size and each listed field sits at the offset of the WGSL member of the
/// same name; every WGSL member but padding must be listed.
macro_rules! assert_mirrors {
    ($rust:ty, $shader:expr, $wgsl:expr, [$($field:ident),* $(,)?]) => {
        $crate::gpu::layout::check_mirror(
            &$shader,
            $wgsl,
            ::std::mem::size_of::<$rust>(),
            &[$((stringify!($field), ::std::mem::offset_of!($rust, $field))),*],
        )
    };
}
pub(crate) use assert_mirrors;
