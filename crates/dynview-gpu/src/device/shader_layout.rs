//! Checking a Rust mirror of a WGSL struct against naga's reflection of the WGSL (tests only):
//! struct size and every member's offset and size, matched by name. Members named `_...` are
//! padding: only the size checks them. Each mirror is declared beside its Rust struct
//! (`wgsl_mirrors` of the modules) and all are checked in `src/layout_tests.rs`.

use naga::{Module, TypeInner};

use crate::device::shaders::Shader;

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
        $crate::device::shader_layout::Mirror {
            shader: $shader,
            wgsl_struct: $wgsl_struct,
            rust_struct: stringify!($ty),
            size: std::mem::size_of::<$ty>(),
            fields: vec![$((stringify!($field), std::mem::offset_of!($ty, $field), std::mem::size_of_val(&zeroed.$field))),*],
        }
    }};
}
pub(crate) use mirror;

/// `shader`'s WGSL parsed by naga (a panic naming the shader where it does not parse).
pub(crate) fn parse((name, source): Shader) -> Module {
    naga::front::wgsl::parse_str(source).unwrap_or_else(|e| panic!("{name}: {}", e.emit_to_string(source)))
}

fn is_padding(field: &str) -> bool {
    field.starts_with('_')
}

/// What differs between `mirror` and its WGSL struct, one line each, naming the shader, the
/// struct and the field.
pub(crate) fn mismatches(mirror: &Mirror) -> Vec<String> {
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
