//! Diffuse shading of a G-buffer from SH irradiance, per fragment (`glsl/shade_sh.frag`):
//! albedo·E(n)/π, with the environment behind.

use crate::error::{Error, Result};
use crate::gpu::layout::{binding, SH_MAX_LMAX};
use crate::gpu::pipeline::{Bind, DescriptorSet, Pipeline};
use crate::gpu::shaders::ShaderId;
use crate::gpu::timing::Spans;
use crate::gpu::{mat3_rows, Buffer, Context, GpuEnvMap, Sampler, Timing};
use crate::math::{sh, Orientation};
use crate::passes::gbuffer::{record_fullscreen, target, GBuffer, FORMAT};
use ash::vk;
use gpu_allocator::MemoryLocation;

/// Push constants of `glsl/shade_sh.frag`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, bytemuck::Pod, bytemuck::Zeroable)]
pub struct ShadeShPush {
    /// Rows of the world → file matrix of the environment.
    pub world_to_file: [[f32; 4]; 3],
    /// Environment layer size.
    pub env_size: [u32; 2],
    /// Environment mapping id.
    pub env_mapping: u32,
    /// Highest SH band.
    pub lmax: u32,
}

/// The SH diffuse shading pass.
pub struct ShadeSh {
    ctx: Context,
    pipeline: Pipeline,
    sampler: Sampler,
}

impl ShadeSh {
    /// Builds the pipeline.
    pub fn new(ctx: &Context) -> Result<ShadeSh> {
        Ok(ShadeSh {
            ctx: ctx.clone(),
            pipeline: Pipeline::fullscreen(
                ctx,
                ShaderId::FullscreenVert,
                ShaderId::ShadeSh,
                &[FORMAT],
            )?,
            sampler: Sampler::linear_clamp(ctx, "shade sampler")?,
        })
    }

    /// Shades `gbuf` with irradiance coefficients `irradiance` (Â_l and any window already
    /// folded in, e.g. [`sh::irradiance_coeffs`]); misses show `env` (oriented by
    /// `orientation`). Returns the frame (linear RGB) and its GPU time.
    pub fn run(
        &self,
        gbuf: &GBuffer,
        irradiance: &[[f64; 3]],
        env: &GpuEnvMap,
        orientation: &Orientation,
    ) -> Result<(GpuEnvMap, Vec<Timing>)> {
        let lmax = (irradiance.len() as f64).sqrt() as u32 - 1;
        if sh::count(lmax) != irradiance.len() || lmax > SH_MAX_LMAX {
            return Err(Error::Invalid(format!(
                "{} SH coefficients are not a full set of bands up to {SH_MAX_LMAX}",
                irradiance.len()
            )));
        }
        let data: Vec<[f32; 4]> = irradiance
            .iter()
            .map(|c| [c[0] as f32, c[1] as f32, c[2] as f32, 0.0])
            .collect();
        let mut coeffs = Buffer::new(
            &self.ctx,
            "shade coefficients",
            (data.len() * 16) as u64,
            vk::BufferUsageFlags::STORAGE_BUFFER,
            MemoryLocation::CpuToGpu,
        )?;
        coeffs.write(&data);
        let frame = target(&self.ctx, "sh shaded frame", gbuf.width, gbuf.height)?;
        let set = DescriptorSet::new(
            &self.ctx,
            &self.pipeline,
            &[
                (
                    binding::SHADE_NORMAL,
                    Bind::Sampled(&gbuf.normal.image, &self.sampler, false),
                ),
                (
                    binding::SHADE_VIEW,
                    Bind::Sampled(&gbuf.view.image, &self.sampler, false),
                ),
                (binding::SHADE_OBJECTS, Bind::Buffer(&gbuf.objects)),
                (binding::SHADE_COEFFS, Bind::Buffer(&coeffs)),
                (
                    binding::SHADE_ENV,
                    Bind::Sampled(&env.image, &self.sampler, false),
                ),
            ],
        )?;
        let push = ShadeShPush {
            world_to_file: mat3_rows(orientation.world_to_file()),
            env_size: [env.width, env.height],
            env_mapping: env.mapping.id(),
            lmax,
        };
        let mut spans = Spans::new(&self.ctx, 1)?;
        self.ctx
            .submit_and_wait("shading with SH irradiance", |cmd| {
                spans.reset(cmd);
                record_fullscreen(
                    &self.ctx,
                    cmd,
                    &mut spans,
                    "shade sh",
                    &self.pipeline,
                    Some(&set),
                    &push,
                    &[&frame.image],
                );
                Ok(())
            })?;
        Ok((frame, spans.read()?))
    }
}
