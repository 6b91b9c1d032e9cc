//! Passes that exist to check the plumbing: a costly dispatch and a fullscreen draw, used to
//! test that timestamps bracket compute work after graphics work has run.

use crate::abi::{binding, push::BusyPush, ShaderId, WORKGROUP_1D};
use crate::error::Result;
use crate::gpu::{groups, Bind, Buffer, Context, Image, ImageDesc, Pipeline, Timing, Usage};
use ash::vk;
use gpu_allocator::MemoryLocation;

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
        let timings = self
            .ctx
            .run("diagnostics", |rec| {
                rec.span("draw", |rec| {
                    rec.draw_fullscreen(&self.draw, &[], &(), &[&target])
                })?;
                rec.span("busy", |rec| {
                    rec.dispatch(
                        &self.busy,
                        &[(binding::BUSY_OUT, Bind::Buffer(&out))],
                        &BusyPush {
                            iterations,
                            count,
                            pad: [0; 2],
                        },
                        [groups(count, WORKGROUP_1D), 1, 1],
                    )
                })?;
                rec.use_buffer(&out, Usage::HostRead);
                Ok(())
            })?
            .timings;
        let sum: f64 = out
            .read::<f32>(count as usize)
            .iter()
            .map(|&v| v as f64)
            .sum();
        Ok((timings, sum))
    }
}
