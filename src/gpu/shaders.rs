//! The committed SPIR-V of every module in the shader table ([`crate::abi::ShaderId`]), and
//! the Vulkan forms of the table's binding kinds. A test checks the table against the SPIR-V.

use crate::abi::{shader_table, Access, Kind, ShaderId};
use ash::vk;

macro_rules! define_spirv {
    ($( $(#[$m:meta])* $id:ident = $name:literal, $file:literal, $stage:ident, [$($d:tt)*],
        $push:ty, $binds:tt; )*
     @shade_variants {
        $( $(#[$vm:meta])* ($plain:ident, $vote:ident, $lean:ident, $vote_lean:ident) =
            $short:literal, [$($tech:ident),*]; )*
     }) => {
        /// The committed SPIR-V of `id`.
        pub fn spirv(id: ShaderId) -> &'static [u8] {
            macro_rules! spv {
                ($stem:expr) => {
                    include_bytes!(concat!(env!("CARGO_MANIFEST_DIR"), "/spirv/", $stem, ".spv"))
                };
            }
            match id {
                $(ShaderId::$id => spv!($name),)*
                $(
                    ShaderId::$plain => spv!(concat!("shade_", $short)),
                    ShaderId::$vote => spv!(concat!("shade_vote_", $short)),
                    ShaderId::$lean => spv!(concat!("shade_lean_", $short)),
                    ShaderId::$vote_lean => spv!(concat!("shade_vote_lean_", $short)),
                )*
            }
        }
    };
}
shader_table!(define_spirv);

/// The Vulkan descriptor type of a binding kind.
pub fn descriptor_type(kind: Kind) -> vk::DescriptorType {
    match kind {
        Kind::Sampled => vk::DescriptorType::COMBINED_IMAGE_SAMPLER,
        Kind::StorageImage => vk::DescriptorType::STORAGE_IMAGE,
        Kind::StorageBuffer => vk::DescriptorType::STORAGE_BUFFER,
        Kind::TexelBuffer => vk::DescriptorType::UNIFORM_TEXEL_BUFFER,
    }
}

/// How a binding of `kind` with `access`, read from `stage`, uses its resource.
pub fn binding_usage(compute: bool, kind: Kind, access: Access) -> super::barrier::Usage {
    use super::barrier::Usage::*;
    match (compute, kind, access) {
        // A uniform texel buffer is read as sampled (synchronization2's SHADER_SAMPLED_READ),
        // not as storage.
        (true, Kind::Sampled | Kind::TexelBuffer, _) => ComputeSampled,
        (false, Kind::Sampled | Kind::TexelBuffer, _) => FragmentSampled,
        (true, _, Access::Read) => ComputeRead,
        (true, _, Access::Write) => ComputeWrite,
        (true, _, Access::ReadWrite) => ComputeReadWrite,
        (false, _, Access::Read) => FragmentRead,
        (false, _, _) => FragmentReadWrite,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gpu::barrier::Usage;

    #[test]
    fn binding_usages_follow_stage_kind_and_access() {
        assert_eq!(
            binding_usage(true, Kind::Sampled, Access::Read),
            Usage::ComputeSampled
        );
        assert_eq!(
            binding_usage(false, Kind::Sampled, Access::Read),
            Usage::FragmentSampled
        );
        assert_eq!(
            binding_usage(true, Kind::StorageImage, Access::Write),
            Usage::ComputeWrite
        );
        assert_eq!(
            binding_usage(true, Kind::TexelBuffer, Access::Read),
            Usage::ComputeSampled
        );
        assert_eq!(
            binding_usage(true, Kind::StorageBuffer, Access::ReadWrite),
            Usage::ComputeReadWrite
        );
        assert_eq!(
            binding_usage(false, Kind::StorageBuffer, Access::Read),
            Usage::FragmentRead
        );
    }

    #[test]
    fn every_module_has_spirv() {
        for &id in ShaderId::ALL {
            assert_eq!(spirv(id)[..4], [0x03, 0x02, 0x23, 0x07], "{id:?}");
        }
    }
}
