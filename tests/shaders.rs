//! spirv/ is in step with glsl/, and every pipeline's bindings and push-constant size agree
//! with what the SPIR-V declares.

// The layout is private to the library; read by path, as tools/shaderc reads it.
#[path = "../src/abi/mod.rs"]
#[allow(dead_code, unused_imports)]
mod layout;

use layout::{Kind, ShaderId, SHADER_SOURCES};
use rspirv_reflect::{DescriptorType, Reflection};
use std::path::Path;

fn root() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

/// The committed SPIR-V of `id`: the file the library embeds (`src/gpu/shaders.rs`
/// includes `spirv/<name>.spv`).
fn spirv(id: ShaderId) -> Vec<u8> {
    std::fs::read(root().join("spirv").join(format!("{}.spv", id.name()))).unwrap()
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
    for &id in ShaderId::ALL {
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
    for &id in ShaderId::ALL {
        let refl = Reflection::new_from_spirv(&spirv(id)).unwrap();
        let sets = refl.get_descriptor_sets().unwrap();
        let iface = id.interface();
        let set0 = sets.get(&0).cloned().unwrap_or_default();
        assert!(
            sets.keys().all(|&s| s == 0),
            "{id:?} uses a set other than 0"
        );
        // Variants whose defines remove code (shade.frag's for one technique) share their
        // source's layout and may leave bindings unread; the bindings of every module of
        // that layout together must still be exactly the interface's.
        let same_layout: Vec<ShaderId> = ShaderId::ALL
            .iter()
            .copied()
            .filter(|o| o.source().file == id.source().file && o.interface() == iface)
            .collect();
        let mut used = std::collections::BTreeSet::new();
        for &o in &same_layout {
            let r = Reflection::new_from_spirv(&spirv(o)).unwrap();
            let sets = r.get_descriptor_sets().unwrap();
            used.extend(
                sets.get(&0)
                    .map(|s| s.keys().copied().collect::<Vec<_>>())
                    .unwrap_or_default(),
            );
        }
        let declared: std::collections::BTreeSet<u32> =
            iface.bindings.iter().map(|b| b.0).collect();
        assert_eq!(used, declared, "{id:?}: bindings of its layout");
        for (&b, info) in &set0 {
            let &(_, kind, _) = iface
                .bindings
                .iter()
                .find(|i| i.0 == b)
                .unwrap_or_else(|| panic!("{id:?}: binding {b} is not in the interface"));
            let want = match kind {
                Kind::Sampled => DescriptorType::COMBINED_IMAGE_SAMPLER,
                Kind::StorageImage => DescriptorType::STORAGE_IMAGE,
                Kind::StorageBuffer => DescriptorType::STORAGE_BUFFER,
                Kind::TexelBuffer => DescriptorType::UNIFORM_TEXEL_BUFFER,
            };
            assert_eq!(info.ty, want, "{id:?}: binding {b} type");
        }
        if same_layout.len() == 1 {
            assert_eq!(set0.len(), iface.bindings.len(), "{id:?}: binding count");
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
            // The source as compiled: its includes (glsl/include/) expanded.
            let text = layout::expand_includes(&root().join("glsl"), id.source().file, 0).unwrap();
            assert!(
                text.contains("local_size_x_id"),
                "{id:?}: workgroup size must be a specialization constant"
            );
        }
    }
}

/// The push-constant block's members in the SPIR-V: (name if kept, byte offset), in order.
fn push_members(words: &[u32]) -> Vec<(Option<String>, u32)> {
    let mut i = 5;
    let mut pointers = std::collections::HashMap::new();
    let mut push_ptr = None;
    let mut offsets: std::collections::BTreeMap<(u32, u32), u32> = Default::default();
    let mut names: std::collections::HashMap<(u32, u32), String> = Default::default();
    while i < words.len() {
        let (count, op) = ((words[i] >> 16) as usize, words[i] & 0xffff);
        let w = &words[i..i + count];
        match op {
            // OpMemberName: type, member, literal string.
            6 => {
                let bytes: Vec<u8> = w[3..].iter().flat_map(|x| x.to_le_bytes()).collect();
                let end = bytes.iter().position(|&b| b == 0).unwrap_or(bytes.len());
                names.insert((w[1], w[2]), String::from_utf8_lossy(&bytes[..end]).into());
            }
            // OpMemberDecorate … Offset.
            72 if w[3] == 35 => {
                offsets.insert((w[1], w[2]), w[4]);
            }
            // OpTypePointer: result, storage class, type.
            32 => {
                pointers.insert(w[1], w[3]);
            }
            // OpVariable: type, result, storage class 9 = PushConstant.
            59 if w[3] == 9 => push_ptr = Some(w[1]),
            _ => {}
        }
        i += count;
    }
    let Some(ptr) = push_ptr else {
        return Vec::new();
    };
    let block = pointers[&ptr];
    offsets
        .iter()
        .filter(|((t, _), _)| *t == block)
        .map(|(&(t, m), &off)| (names.get(&(t, m)).cloned(), off))
        .collect()
}

/// Every push block is generated from the Rust struct, and the compiled SPIR-V agrees with
/// the struct field by field: same order, same offsets, same names where the SPIR-V keeps them.
#[test]
fn push_blocks_match_the_rust_structs_field_by_field() {
    let mut checked = 0;
    for &id in ShaderId::ALL {
        let words: Vec<u32> = spirv(id)
            .chunks_exact(4)
            .map(|c| u32::from_le_bytes([c[0], c[1], c[2], c[3]]))
            .collect();
        let got = push_members(&words);
        let want = id.interface().push_fields;
        assert_eq!(got.len(), want.len(), "{id:?}: push block member count");
        for ((name, off), &(field, _, offset)) in got.iter().zip(want) {
            assert_eq!(*off as usize, offset, "{id:?}: offset of {field}");
            if let Some(name) = name {
                assert_eq!(name, field, "{id:?}: member at offset {offset}");
            }
        }
        if let Some(block) = id.push_block() {
            // The source as compiled: its includes (glsl/include/) expanded.
            let text = layout::expand_includes(&root().join("glsl"), id.source().file, 0).unwrap();
            assert!(
                text.contains(&format!("PUSH_{block}")),
                "{id:?}: the shader must use the generated PUSH_{block}"
            );
            // The generated header's PUSH_ macros are the one place a block is declared.
            assert!(
                !text
                    .lines()
                    .any(|l| !l.starts_with("#define PUSH_") && l.contains("push_constant")),
                "{id:?}: a hand-written push block"
            );
        }
        checked += got.len();
    }
    assert!(checked > 50, "only {checked} push members found");
}

/// The examples' own shaders (an engine's, compiled by tools/shaderc beside their source) are
/// in step with their source: the hash recorded at compilation is the current source's, and
/// the module is SPIR-V.
#[test]
fn example_shaders_are_not_stale() {
    for path in layout::EXAMPLE_SHADERS {
        let source = std::fs::read_to_string(root().join(format!("{path}.comp"))).unwrap();
        let recorded = std::fs::read_to_string(root().join(format!("{path}.spv.hash"))).unwrap();
        assert_eq!(
            recorded.trim(),
            format!("{:016x}", layout::example_hash(&source)),
            "{path}.spv is stale against {path}.comp: run `cargo xtask shaders`"
        );
        let spv = std::fs::read(root().join(format!("{path}.spv"))).unwrap();
        assert_eq!(
            &spv[..4],
            &0x0723_0203u32.to_le_bytes(),
            "{path}.spv is not SPIR-V"
        );
    }
}
