//! Barriers described as "usage before → usage after" (vk-sync's idea), mapped to stages,
//! access masks and image layouts by small pure functions.

use ash::vk;

/// How a resource is used on one side of a barrier.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Usage {
    /// Contents are undefined (a new image, or one whose contents are discarded).
    Undefined,
    /// Source of a transfer (copy).
    TransferSrc,
    /// Destination of a transfer (copy, clear).
    TransferDst,
    /// Sampled or fetched by a compute shader.
    ComputeSampled,
    /// Written as a storage image or buffer by a compute shader.
    ComputeWrite,
    /// Read as a storage buffer by a compute shader.
    ComputeRead,
    /// Read and written as storage (an accumulation across dispatches).
    ComputeReadWrite,
    /// Sampled by a fragment shader.
    FragmentSampled,
    /// Read as a storage buffer or image by a fragment shader.
    FragmentRead,
    /// Read and written as storage by a fragment shader.
    FragmentReadWrite,
    /// Written as a colour attachment.
    ColorAttachment,
    /// Read as the arguments of an indirect dispatch.
    IndirectRead,
    /// Read by the host after the GPU is done.
    HostRead,
    /// Written by the host before the GPU reads it.
    HostWrite,
}

/// Stage, access and layout of a [`Usage`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct UsageInfo {
    /// Pipeline stages involved.
    pub stage: vk::PipelineStageFlags2,
    /// Memory accesses made.
    pub access: vk::AccessFlags2,
    /// Image layout required.
    pub layout: vk::ImageLayout,
}

/// The stage, access and layout a usage implies.
pub fn usage_info(u: Usage) -> UsageInfo {
    use vk::{AccessFlags2 as A, ImageLayout as L, PipelineStageFlags2 as S};
    let (stage, access, layout) = match u {
        Usage::Undefined => (S::TOP_OF_PIPE, A::NONE, L::UNDEFINED),
        Usage::TransferSrc => (S::COPY, A::TRANSFER_READ, L::TRANSFER_SRC_OPTIMAL),
        Usage::TransferDst => (
            S::COPY | S::CLEAR,
            A::TRANSFER_WRITE,
            L::TRANSFER_DST_OPTIMAL,
        ),
        Usage::ComputeSampled => (
            S::COMPUTE_SHADER,
            A::SHADER_SAMPLED_READ,
            L::SHADER_READ_ONLY_OPTIMAL,
        ),
        Usage::ComputeWrite => (S::COMPUTE_SHADER, A::SHADER_STORAGE_WRITE, L::GENERAL),
        Usage::ComputeRead => (S::COMPUTE_SHADER, A::SHADER_STORAGE_READ, L::GENERAL),
        Usage::ComputeReadWrite => (
            S::COMPUTE_SHADER,
            A::SHADER_STORAGE_READ | A::SHADER_STORAGE_WRITE,
            L::GENERAL,
        ),
        Usage::FragmentSampled => (
            S::FRAGMENT_SHADER,
            A::SHADER_SAMPLED_READ,
            L::SHADER_READ_ONLY_OPTIMAL,
        ),
        Usage::FragmentRead => (S::FRAGMENT_SHADER, A::SHADER_STORAGE_READ, L::GENERAL),
        Usage::FragmentReadWrite => (
            S::FRAGMENT_SHADER,
            A::SHADER_STORAGE_READ | A::SHADER_STORAGE_WRITE,
            L::GENERAL,
        ),
        Usage::ColorAttachment => (
            S::COLOR_ATTACHMENT_OUTPUT,
            A::COLOR_ATTACHMENT_WRITE | A::COLOR_ATTACHMENT_READ,
            L::COLOR_ATTACHMENT_OPTIMAL,
        ),
        Usage::IndirectRead => (S::DRAW_INDIRECT, A::INDIRECT_COMMAND_READ, L::GENERAL),
        Usage::HostRead => (S::HOST, A::HOST_READ, L::GENERAL),
        Usage::HostWrite => (S::HOST, A::HOST_WRITE, L::GENERAL),
    };
    UsageInfo {
        stage,
        access,
        layout,
    }
}

impl Usage {
    /// Whether the usage writes.
    pub fn writes(self) -> bool {
        matches!(
            self,
            Usage::TransferDst
                | Usage::ComputeWrite
                | Usage::ComputeReadWrite
                | Usage::FragmentReadWrite
                | Usage::ColorAttachment
                | Usage::HostWrite
        )
    }
}

/// Whether an image going from `before` to `after` needs a barrier: any write on either side
/// (RAW, WAR, WAW), a layout change, or a read by a stage the last barrier did not cover.
pub fn needs_barrier(before: Usage, after: Usage) -> bool {
    buffer_needs_barrier(before, after) || usage_info(before).layout != usage_info(after).layout
}

/// As [`needs_barrier`] for a buffer, which has no layout.
pub fn buffer_needs_barrier(before: Usage, after: Usage) -> bool {
    before != Usage::Undefined && (before != after || after.writes())
}

/// A barrier for all mips and layers of a colour image.
pub fn image_barrier(
    image: vk::Image,
    layers: u32,
    before: Usage,
    after: Usage,
) -> vk::ImageMemoryBarrier2<'static> {
    let (b, a) = (usage_info(before), usage_info(after));
    vk::ImageMemoryBarrier2::default()
        .src_stage_mask(b.stage)
        .src_access_mask(b.access)
        .dst_stage_mask(a.stage)
        .dst_access_mask(a.access)
        .old_layout(b.layout)
        .new_layout(a.layout)
        .src_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
        .dst_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
        .image(image)
        .subresource_range(
            vk::ImageSubresourceRange::default()
                .aspect_mask(vk::ImageAspectFlags::COLOR)
                .base_mip_level(0)
                .level_count(vk::REMAINING_MIP_LEVELS)
                .base_array_layer(0)
                .layer_count(layers),
        )
}

/// A global memory barrier (buffers, and images whose layout stays).
pub fn memory_barrier(before: Usage, after: Usage) -> vk::MemoryBarrier2<'static> {
    let (b, a) = (usage_info(before), usage_info(after));
    vk::MemoryBarrier2::default()
        .src_stage_mask(b.stage)
        .src_access_mask(b.access)
        .dst_stage_mask(a.stage)
        .dst_access_mask(a.access)
}

/// A barrier that orders everything before it against everything after it. Used after each
/// timestamp write: Mesa 22.3's lavapipe otherwise lets a timestamp written before a compute
/// dispatch land after it once graphics work has run.
pub fn full_barrier() -> vk::MemoryBarrier2<'static> {
    vk::MemoryBarrier2::default()
        .src_stage_mask(vk::PipelineStageFlags2::ALL_COMMANDS)
        .src_access_mask(vk::AccessFlags2::MEMORY_READ | vk::AccessFlags2::MEMORY_WRITE)
        .dst_stage_mask(vk::PipelineStageFlags2::ALL_COMMANDS)
        .dst_access_mask(vk::AccessFlags2::MEMORY_READ | vk::AccessFlags2::MEMORY_WRITE)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn upload_then_sample_transitions_layouts() {
        let b = image_barrier(
            vk::Image::null(),
            6,
            Usage::TransferDst,
            Usage::ComputeSampled,
        );
        assert_eq!(b.old_layout, vk::ImageLayout::TRANSFER_DST_OPTIMAL);
        assert_eq!(b.new_layout, vk::ImageLayout::SHADER_READ_ONLY_OPTIMAL);
        assert!(b.src_access_mask.contains(vk::AccessFlags2::TRANSFER_WRITE));
        assert_eq!(b.dst_stage_mask, vk::PipelineStageFlags2::COMPUTE_SHADER);
        assert_eq!(b.subresource_range.layer_count, 6);
    }

    #[test]
    fn undefined_waits_on_nothing() {
        let b = image_barrier(vk::Image::null(), 1, Usage::Undefined, Usage::ComputeWrite);
        assert_eq!(b.src_access_mask, vk::AccessFlags2::NONE);
        assert_eq!(b.old_layout, vk::ImageLayout::UNDEFINED);
        assert_eq!(b.new_layout, vk::ImageLayout::GENERAL);
    }

    #[test]
    fn every_write_usage_has_write_access_and_reads_have_none() {
        let writes = [
            Usage::TransferDst,
            Usage::ComputeWrite,
            Usage::ComputeReadWrite,
            Usage::ColorAttachment,
            Usage::HostWrite,
        ];
        let write_bits = vk::AccessFlags2::TRANSFER_WRITE
            | vk::AccessFlags2::SHADER_STORAGE_WRITE
            | vk::AccessFlags2::COLOR_ATTACHMENT_WRITE
            | vk::AccessFlags2::HOST_WRITE;
        for u in writes {
            assert!(usage_info(u).access.intersects(write_bits), "{u:?}");
        }
        for u in [
            Usage::TransferSrc,
            Usage::ComputeSampled,
            Usage::ComputeRead,
            Usage::FragmentSampled,
            Usage::FragmentRead,
            Usage::IndirectRead,
            Usage::HostRead,
        ] {
            assert!(!usage_info(u).access.intersects(write_bits), "{u:?}");
            assert!(!u.writes(), "{u:?}");
        }
    }

    #[test]
    fn barriers_only_where_a_hazard_or_layout_change_is() {
        // Read after read in the same stage and layout: nothing to wait for.
        assert!(!needs_barrier(Usage::ComputeSampled, Usage::ComputeSampled));
        // A new image: only its layout changes.
        assert!(needs_barrier(Usage::Undefined, Usage::ComputeWrite));
        // RAW, WAW, WAR.
        assert!(needs_barrier(Usage::ComputeWrite, Usage::ComputeSampled));
        assert!(needs_barrier(
            Usage::ComputeReadWrite,
            Usage::ComputeReadWrite
        ));
        assert!(needs_barrier(Usage::FragmentSampled, Usage::ComputeWrite));
        // The same layout read by another stage still needs the writes made visible there.
        assert!(needs_barrier(Usage::ComputeSampled, Usage::FragmentSampled));
    }

    #[test]
    fn host_read_after_compute_write_is_a_memory_dependency() {
        let m = memory_barrier(Usage::ComputeWrite, Usage::HostRead);
        assert_eq!(m.src_stage_mask, vk::PipelineStageFlags2::COMPUTE_SHADER);
        assert_eq!(m.dst_access_mask, vk::AccessFlags2::HOST_READ);
    }
}
