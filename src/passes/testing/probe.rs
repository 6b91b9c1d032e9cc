//! Exposes the GLSL mapping functions (round trips and texel solid angles) so tests can hold
//! them against the float64 versions.

use crate::abi::{binding, push::ProbePush, ShaderId, WORKGROUP_1D};
use crate::error::Result;
use crate::gpu::{groups, Bind, Buffer, Context, Pipeline, Usage};
use crate::math::Mapping;
use ash::vk;
use gpu_allocator::MemoryLocation;

/// One round trip through the GLSL mapping functions.
#[derive(Clone, Copy, Debug)]
pub struct RoundTrip {
    /// Layer from `dir_to_coord`.
    pub layer: u32,
    /// Texture coordinate from `dir_to_coord`.
    pub uv: [f32; 2],
    /// Direction from `coord_to_dir` of that coordinate.
    pub dir: [f32; 3],
}

/// The mapping probe pass.
pub struct MappingProbe {
    ctx: Context,
    pipeline: Pipeline,
}

impl MappingProbe {
    /// Builds the pipeline.
    pub fn new(ctx: &Context) -> Result<MappingProbe> {
        Ok(MappingProbe {
            ctx: ctx.clone(),
            pipeline: Pipeline::compute(ctx, ShaderId::MappingProbe, &[WORKGROUP_1D])?,
        })
    }

    fn run(&self, push: ProbePush, input: &[[f32; 4]], out_len: usize) -> Result<Vec<[f32; 4]>> {
        let mut inb = Buffer::new(
            &self.ctx,
            "probe input",
            (input.len().max(1) * 16) as u64,
            vk::BufferUsageFlags::STORAGE_BUFFER,
            MemoryLocation::CpuToGpu,
        )?;
        if !input.is_empty() {
            inb.write(input);
        }
        let outb = Buffer::new(
            &self.ctx,
            "probe output",
            (out_len * 16) as u64,
            vk::BufferUsageFlags::STORAGE_BUFFER,
            MemoryLocation::GpuToCpu,
        )?;
        self.ctx.run("mapping probe", |rec| {
            rec.dispatch(
                &self.pipeline,
                &[
                    (binding::PROBE_IN, Bind::Buffer(&inb)),
                    (binding::PROBE_OUT, Bind::Buffer(&outb)),
                ],
                &push,
                [groups(push.count, WORKGROUP_1D), 1, 1],
            )?;
            rec.use_buffer(&outb, Usage::HostRead);
            Ok(())
        })?;
        Ok(outb.read(out_len))
    }

    /// Runs `dir_to_coord` then `coord_to_dir` on each direction.
    pub fn round_trip(&self, mapping: Mapping, dirs: &[[f32; 3]]) -> Result<Vec<RoundTrip>> {
        let input: Vec<[f32; 4]> = dirs.iter().map(|d| [d[0], d[1], d[2], 0.0]).collect();
        let push = ProbePush {
            mode: 0,
            mapping: mapping.id(),
            count: dirs.len() as u32,
            ..Default::default()
        };
        let out = self.run(push, &input, 2 * dirs.len())?;
        Ok(out
            .chunks_exact(2)
            .map(|c| RoundTrip {
                layer: c[0][2] as u32,
                uv: [c[0][0], c[0][1]],
                dir: [c[1][0], c[1][1], c[1][2]],
            })
            .collect())
    }

    /// The GLSL texel solid angles of a `w × h` layer, row-major.
    pub fn solid_angles(&self, mapping: Mapping, w: u32, h: u32) -> Result<Vec<f32>> {
        let push = ProbePush {
            mode: 1,
            mapping: mapping.id(),
            count: w * h,
            width: w,
            height: h,
            ..Default::default()
        };
        Ok(self
            .run(push, &[], (w * h) as usize)?
            .into_iter()
            .map(|v| v[0])
            .collect())
    }
}
