//! The Rust mirrors of every WGSL uniform and storage struct of the crate against naga's
//! reflection of the WGSL (`device/shader_layout.rs`): each mirror matches, every struct a
//! shader binds has one, and a mismatch is reported by shader, struct and field. The mirrors are
//! gathered here, above every layer that declares them.

use naga::{AddressSpace, TypeInner};

use crate::device::shader_layout::{Mirror, mismatches, parse};
use crate::device::shaders::SHADERS;

/// Every mirror of the crate, declared beside its Rust struct.
fn all_mirrors() -> Vec<Mirror> {
    [
        crate::device::image::wgsl_mirrors(),
        crate::passes::assemble::wgsl_mirrors(),
        crate::passes::blend::wgsl_mirrors(),
        crate::passes::rank::wgsl_mirrors(),
        crate::passes::consistency::wgsl_mirrors(),
        crate::passes::pyramid::wgsl_mirrors(),
        crate::passes::solver::wgsl_mirrors(),
        crate::passes::splat::wgsl_mirrors(),
        crate::passes::static_mask::wgsl_mirrors(),
        crate::passes::temporal::wgsl_mirrors(),
        crate::passes::warp::wgsl_mirrors(),
        crate::render::display::wgsl_mirrors(),
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
    let mut mirror = crate::passes::assemble::wgsl_mirrors().remove(0);
    let field = mirror.fields.iter_mut().find(|(name, ..)| *name == "lambda_p").unwrap_or_else(|| panic!("no lambda_p"));
    field.1 += 4;
    mirror.size += 16;
    let failures = mismatches(&mirror);
    assert_eq!(failures.len(), 2, "{failures:?}");
    assert!(failures[0].contains("size is 64 bytes in the WGSL, 80 in Rust"), "{}", failures[0]);
    let offset = &failures[1];
    assert!(offset.contains(mirror.shader.0) && offset.contains("struct Params") && offset.contains("field lambda_p"), "{offset}");
}
