//! spirv/ is in step with glsl/, and every pipeline's bindings and push-constant size agree
//! with what the SPIR-V declares.

use envlight::gpu::layout::{self, SHADER_SOURCES};
use envlight::gpu::shaders::{DescriptorKind, ShaderId};
use rspirv_reflect::{DescriptorType, Reflection};
use std::path::Path;

fn root() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

#[test]
fn spirv_is_not_stale() {
    let header = std::fs::read_to_string(root().join(layout::GENERATED_HEADER)).unwrap();
    assert_eq!(
        header,
        layout::generated_header(),
        "{} is out of date: run `cargo xtask shaders`",
        layout::GENERATED_HEADER
    );
    let manifest = std::fs::read_to_string(root().join(layout::MANIFEST)).unwrap();
    let now = layout::manifest(&root().join("glsl")).unwrap();
    assert_eq!(
        manifest, now,
        "spirv/ is stale against glsl/: run `cargo xtask shaders`"
    );
    for s in SHADER_SOURCES {
        let p = root().join("spirv").join(format!("{}.spv", s.name));
        let bytes = std::fs::read(&p).unwrap();
        assert!(
            bytes.len() > 20 && bytes[..4] == [0x03, 0x02, 0x23, 0x07],
            "{} is not SPIR-V",
            p.display()
        );
    }
}

#[test]
fn every_shader_is_registered_once() {
    assert_eq!(ShaderId::ALL.len(), SHADER_SOURCES.len());
    for id in ShaderId::ALL {
        assert_eq!(
            ShaderId::ALL
                .iter()
                .filter(|o| o.source().name == id.source().name)
                .count(),
            1
        );
    }
}

#[test]
fn bindings_and_push_constants_match_the_spirv() {
    for id in ShaderId::ALL {
        let refl = Reflection::new_from_spirv(id.spirv()).unwrap();
        let sets = refl.get_descriptor_sets().unwrap();
        let iface = id.interface();
        let set0 = sets.get(&0).cloned().unwrap_or_default();
        assert!(
            sets.keys().all(|&s| s == 0),
            "{id:?} uses a set other than 0"
        );
        assert_eq!(set0.len(), iface.bindings.len(), "{id:?}: binding count");
        for &(b, kind) in iface.bindings {
            let info = set0
                .get(&b)
                .unwrap_or_else(|| panic!("{id:?}: SPIR-V has no binding {b}"));
            let want = match kind {
                DescriptorKind::SampledImage => DescriptorType::COMBINED_IMAGE_SAMPLER,
                DescriptorKind::StorageImage => DescriptorType::STORAGE_IMAGE,
                DescriptorKind::StorageBuffer => DescriptorType::STORAGE_BUFFER,
            };
            assert_eq!(info.ty, want, "{id:?}: binding {b} type");
        }
        let push = refl.get_push_constant_range().unwrap();
        match push {
            Some(p) => assert_eq!(
                p.offset + p.size,
                iface.push_size,
                "{id:?}: push constant size"
            ),
            None => assert_eq!(
                iface.push_size, 0,
                "{id:?}: Rust pushes constants the shader lacks"
            ),
        }
        // Compute workgroup sizes come from specialization constants, never literals.
        if id.source().stage == layout::Stage::Compute {
            let text = std::fs::read_to_string(root().join("glsl").join(id.source().file)).unwrap();
            assert!(
                text.contains("local_size_x_id"),
                "{id:?}: workgroup size must be a specialization constant"
            );
        }
    }
}
