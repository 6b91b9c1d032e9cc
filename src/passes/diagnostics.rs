//! Passes that exist to check the plumbing: a costly dispatch and a fullscreen draw, used to
//! test that timestamps bracket compute work after graphics work has run.

use crate::error::Result;
use crate::gpu::barrier::{cmd_memory_barrier, memory_barrier, Usage};
use crate::gpu::layout::{binding, WORKGROUP_1D};
use crate::gpu::pipeline::{Bind, DescriptorSet, Pipeline};
use crate::gpu::shaders::ShaderId;
use crate::gpu::timing::Spans;
use crate::gpu::{groups, Buffer, Context, Image, ImageDesc, Timing};
use crate::passes::gbuffer::record_fullscreen;
use ash::vk;
use gpu_allocator::MemoryLocation;

/// Push constants of `glsl/busy.comp`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, bytemuck::Pod, bytemuck::Zeroable)]
pub struct BusyPush {
    /// Loop iterations per invocation.
    pub iterations: u32,
    /// Invocations.
    pub count: u32,
    /// Padding.
    pub pad: [u32; 2],
}

/// A fullscreen draw followed by a costly dispatch, each timed.
pub struct Diagnostics {
    ctx: Context,
    busy: Pipeline,
    draw: Pipeline,
}

const DRAW_FORMAT: vk::Format = vk::Format::R8G8B8A8_UNORM;

impl Diagnostics {
    /// Builds both pipelines.
    pub fn new(ctx: &Context) -> Result<Diagnostics> {
        Ok(Diagnostics {
            ctx: ctx.clone(),
            busy: Pipeline::compute(ctx, ShaderId::Busy, &[WORKGROUP_1D])?,
            draw: Pipeline::fullscreen(
                ctx,
                ShaderId::FullscreenVert,
                ShaderId::FlatFrag,
                &[DRAW_FORMAT],
            )?,
        })
    }

    /// Draws into a `size²` image, then runs `count` invocations of `iterations` loop steps;
    /// returns the timings of both ("draw", then "busy") and the checksum of the results.
    pub fn draw_then_busy(
        &self,
        size: u32,
        iterations: u32,
        count: u32,
    ) -> Result<(Vec<Timing>, f64)> {
        let target = Image::new(
            &self.ctx,
            "diagnostics target",
            ImageDesc {
                width: size,
                height: size,
                layers: 1,
                format: DRAW_FORMAT,
                usage: vk::ImageUsageFlags::COLOR_ATTACHMENT | vk::ImageUsageFlags::SAMPLED,
                cube: false,
                mips: 1,
            },
        )?;
        let out = Buffer::new(
            &self.ctx,
            "busy output",
            (count as u64) * 4,
            vk::BufferUsageFlags::STORAGE_BUFFER,
            MemoryLocation::GpuToCpu,
        )?;
        let set = DescriptorSet::new(
            &self.ctx,
            &self.busy,
            &[(binding::BUSY_OUT, Bind::Buffer(&out))],
        )?;
        let mut spans = Spans::new(&self.ctx, 2)?;
        let d = self.ctx.device();
        self.ctx.submit_and_wait("diagnostics", |cmd| {
            spans.reset(cmd);
            record_fullscreen(
                &self.ctx,
                cmd,
                &mut spans,
                "draw",
                &self.draw,
                None,
                &(),
                &[&target],
            );
            let span = spans.begin(cmd, "busy");
            self.busy.bind(
                cmd,
                Some(&set),
                &BusyPush {
                    iterations,
                    count,
                    pad: [0; 2],
                },
            );
            // SAFETY: cmd is recording with the compute pipeline bound.
            unsafe { d.cmd_dispatch(cmd, groups(count, WORKGROUP_1D), 1, 1) };
            spans.end(cmd, span);
            cmd_memory_barrier(d, cmd, memory_barrier(Usage::ComputeWrite, Usage::HostRead));
            Ok(())
        })?;
        let sum: f64 = out
            .read::<f32>(count as usize)
            .iter()
            .map(|&v| v as f64)
            .sum();
        let timings = spans.read()?;
        Ok((timings, sum))
    }
}
