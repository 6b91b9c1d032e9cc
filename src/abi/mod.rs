//! The shared ABI: everything GLSL and Rust must agree on, written once, a file per kind of
//! declaration: binding numbers ([`binding`]), the numbers both sides use ([`parameters`]:
//! ids, tuning parameters, workgroup sizes), the push-constant blocks ([`push`]: Rust structs
//! and the GLSL blocks generated from the same list), the per-object record ([`record`], the
//! same way), the shader table ([`shaders`]: every
//! module with its source, bindings and access), and the generator of the GLSL header
//! ([`generate`]).
//!
//! These files are self-contained (std only) because `tools/shaderc` includes them by path to
//! write `glsl/include/generated.glsl` and `spirv/manifest.txt` without building the library.
//! They are the bottom of the import order (`tests/layering.rs`).

pub mod binding;
pub mod generate;
pub mod parameters;
pub mod push;
pub mod record;
pub mod shaders;

pub use generate::{
    example_hash, expand_includes, fnv1a, fnv1a_bytes, generated_header, manifest, source_hash,
    EXAMPLE_SHADERS,
};
pub use parameters::*;
pub use push::PushBlock;
pub(crate) use shaders::shader_table;
pub use shaders::*;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn constants_are_what_their_docs_say() {
        assert_eq!(constants::GAUSS2_OFFSET, 0.5 / 3f64.sqrt());
        assert!((filter_rule::LOG_CUTOFF - 1e-10f64.ln()).abs() < 1e-12);
        let l = constants::LUMINANCE;
        assert!((l[0] + l[1] + l[2] - 1.0).abs() < 1e-12);
    }

    #[test]
    fn every_binding_of_the_table_is_named_once_in_its_shader() {
        for &id in ShaderId::ALL {
            let b = id.interface().bindings;
            for (i, x) in b.iter().enumerate() {
                assert!(
                    b[i + 1..].iter().all(|y| y.0 != x.0),
                    "{id:?}: binding {}",
                    x.0
                );
            }
            assert_eq!(id.source().name, id.name());
            assert_eq!(ShaderId::ALL[id as usize], id);
        }
    }

    #[test]
    fn the_header_defines_every_push_block_record_and_binding() {
        let h = generated_header();
        for (name, _) in push::PUSH_BLOCKS {
            assert!(h.contains(&format!("#define PUSH_{name} ")), "{name}");
        }
        for (name, fields) in record::RECORDS {
            assert!(h.contains(&format!("struct {name} {{\n")), "{name}");
            for (field, ty, _) in fields.iter() {
                assert!(
                    h.contains(&format!("    {ty} {field};\n")),
                    "{name}.{field}"
                );
            }
        }
        for (name, v) in binding::ALL {
            assert!(
                h.contains(&format!("#define BINDING_{name} {v}\n")),
                "{name}"
            );
        }
    }
}
