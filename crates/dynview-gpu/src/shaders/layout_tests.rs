//! The Rust mirrors of the WGSL uniform blocks against naga's reflection of the WGSL: struct
//! size and every member's offset and size, matched by name. Members named `_...` are padding:
//! only the size checks them.

use naga::{AddressSpace, Module, TypeInner};

use super::{SHADERS, Shader};

/// A Rust `Pod` struct that mirrors a WGSL struct of a shader.
pub(crate) struct Mirror {
    /// The shader whose WGSL defines the struct.
    pub(crate) shader: Shader,
    /// The struct's name in the WGSL.
    pub(crate) wgsl_struct: &'static str,
    /// The mirror's name in Rust.
    pub(crate) rust_struct: &'static str,
    /// `size_of` the mirror.
    pub(crate) size: usize,
    /// `(name, offset, size)` of every field of the mirror.
    pub(crate) fields: Vec<(&'static str, usize, usize)>,
}

/// `mirror!(SHADER, "WgslStruct", RustStruct { field, ... })`: the layout of `RustStruct`, whose
/// fields must all be listed (the pattern is exhaustive).
macro_rules! mirror {
    ($shader:expr, $wgsl_struct:literal, $ty:ident { $($field:ident),* $(,)? }) => {{
        let zeroed: $ty = bytemuck::Zeroable::zeroed();
        let $ty { $($field: _),* } = zeroed;
        $crate::shaders::layout_tests::Mirror {
            shader: $shader,
            wgsl_struct: $wgsl_struct,
            rust_struct: stringify!($ty),
            size: std::mem::size_of::<$ty>(),
            fields: vec![$((stringify!($field), std::mem::offset_of!($ty, $field), std::mem::size_of_val(&zeroed.$field))),*],
        }
    }};
}
pub(crate) use mirror;

fn parse((name, source): Shader) -> Module {
    naga::front::wgsl::parse_str(source).unwrap_or_else(|e| panic!("{name}: {}", e.emit_to_string(source)))
}

fn is_padding(field: &str) -> bool {
    field.starts_with('_')
}

/// What differs between `mirror` and its WGSL struct, one line each, naming the shader, the
/// struct and the field.
fn mismatches(mirror: &Mirror) -> Vec<String> {
    let module = parse(mirror.shader);
    let at = |what: &str| format!("{}: struct {} (Rust {}): {what}", mirror.shader.0, mirror.wgsl_struct, mirror.rust_struct);
    let Some((members, span)) = module.types.iter().find_map(|(_, ty)| match &ty.inner {
        TypeInner::Struct { members, span } if ty.name.as_deref() == Some(mirror.wgsl_struct) => Some((members, *span)),
        _ => None,
    }) else {
        return vec![at("not in the WGSL")];
    };
    let mut out = Vec::new();
    if span as usize != mirror.size {
        out.push(at(&format!("size is {span} bytes in the WGSL, {} in Rust", mirror.size)));
    }
    for member in members {
        let name = member.name.as_deref().unwrap_or_default();
        if is_padding(name) {
            continue;
        }
        let Some(&(_, offset, size)) = mirror.fields.iter().find(|(field, ..)| *field == name) else {
            out.push(at(&format!("field {name} is missing in Rust")));
            continue;
        };
        if member.offset as usize != offset {
            out.push(at(&format!("field {name} is at offset {} in the WGSL, {offset} in Rust", member.offset)));
        }
        let wgsl_size = module.types[member.ty].inner.size(module.to_ctx()) as usize;
        if wgsl_size != size {
            out.push(at(&format!("field {name} has {wgsl_size} bytes in the WGSL, {size} in Rust")));
        }
    }
    for (field, ..) in mirror.fields.iter().filter(|(field, ..)| !is_padding(field)) {
        if !members.iter().any(|m| m.name.as_deref() == Some(field)) {
            out.push(at(&format!("field {field} is not in the WGSL")));
        }
    }
    out
}

/// Every mirror of the crate, declared beside its Rust struct.
fn all_mirrors() -> Vec<Mirror> {
    [
        crate::assemble::wgsl_mirrors(),
        crate::blend::wgsl_mirrors(),
        crate::rank::wgsl_mirrors(),
        crate::consistency::wgsl_mirrors(),
        crate::display::wgsl_mirrors(),
        crate::image::wgsl_mirrors(),
        crate::solver::wgsl_mirrors(),
        crate::splat::wgsl_mirrors(),
        crate::temporal::wgsl_mirrors(),
        crate::warp::wgsl_mirrors(),
    ]
    .into_iter()
    .flatten()
    .collect()
}

#[test]
fn rust_mirrors_match_the_wgsl_structs() {
    let failures: Vec<String> = all_mirrors().iter().flat_map(mismatches).collect();
    assert!(failures.is_empty(), "Rust mirrors disagree with the WGSL:\n{}", failures.join("\n"));
}

#[test]
fn every_uniform_and_storage_struct_has_a_rust_mirror() {
    let mirrors = all_mirrors();
    for &shader in SHADERS {
        let module = parse(shader);
        for (_, global) in module.global_variables.iter() {
            if !matches!(global.space, AddressSpace::Uniform | AddressSpace::Storage { .. }) {
                continue;
            }
            let mut ty = &module.types[global.ty];
            if let TypeInner::Array { base, .. } = ty.inner {
                ty = &module.types[base];
            }
            if let (TypeInner::Struct { .. }, Some(name)) = (&ty.inner, ty.name.as_deref()) {
                let mirrored = mirrors.iter().any(|m| m.shader.0 == shader.0 && m.wgsl_struct == name);
                assert!(mirrored, "{}: struct {name} (bound as {:?}) has no Rust mirror checked here", shader.0, global.name);
            }
        }
    }
}

#[test]
fn a_wrong_offset_or_size_is_reported_by_shader_struct_and_field() {
    let mut mirror = crate::assemble::wgsl_mirrors().remove(0);
    let field = mirror.fields.iter_mut().find(|(name, ..)| *name == "lambda_p").unwrap_or_else(|| panic!("no lambda_p"));
    field.1 += 4;
    mirror.size += 16;
    let failures = mismatches(&mirror);
    assert_eq!(failures.len(), 2, "{failures:?}");
    assert!(failures[0].contains("size is 64 bytes in the WGSL, 80 in Rust"), "{}", failures[0]);
    let offset = &failures[1];
    assert!(offset.contains(mirror.shader.0) && offset.contains("struct Params") && offset.contains("field lambda_p"), "{offset}");
}
