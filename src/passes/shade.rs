//! The shading pass (`glsl/shade.frag`): one fullscreen draw that shades each G-buffer pixel
//! by its material's technique (mirror lookup, SH irradiance, prefiltered maps, filtered
//! importance sampling, or the Monte Carlo accumulation) and shows the environment behind.

use crate::error::Result;
use crate::gpu::layout::binding;
use crate::gpu::pipeline::{Bind, DescriptorSet, Pipeline};
use crate::gpu::shaders::ShaderId;
use crate::gpu::timing::Spans;
use crate::gpu::{mat3_rows, Buffer, Context, GpuEnvMap, Sampler, Timing};
use crate::math::{Mapping, Orientation};
use crate::passes::gbuffer::{record_fullscreen, target, GBuffer, FORMAT};
use crate::EnvMap;

/// Push constants of `glsl/shade.frag`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, bytemuck::Pod, bytemuck::Zeroable)]
pub struct ShadePush {
    /// Rows of the world → file matrix of the environment.
    pub world_to_file: [[f32; 4]; 3],
    /// Environment layer size.
    pub env_size: [u32; 2],
    /// Environment mapping id.
    pub env_mapping: u32,
    /// Number of objects.
    pub count: u32,
    /// Side of the dual paraboloid's level 0.
    pub dp_size: u32,
    /// Its last MIP level.
    pub max_lod: f32,
    /// 1: shadow rays for lookups and FIS samples.
    pub shadows: u32,
    /// Samples in the Monte Carlo accumulation.
    pub mc_samples: u32,
}

/// What the shading reads besides the G-buffer; techniques no material uses are `None`.
pub struct ShadeInputs<'a> {
    /// The environment in its own mapping (background and mirror lookups).
    pub env: &'a GpuEnvMap,
    /// How its file is oriented.
    pub orientation: Orientation,
    /// SH irradiance coefficient sets, concatenated (each object's record holds its offset).
    pub sh: Option<&'a [[f64; 3]]>,
    /// The dual-paraboloid MIP chain (FIS).
    pub dp: Option<&'a GpuEnvMap>,
    /// Prefiltered lat-long maps, concatenated, one vec4 per texel.
    pub prefiltered: Option<&'a Buffer>,
    /// The Monte Carlo accumulation and its sample count.
    pub mc: Option<(&'a GpuEnvMap, u32)>,
    /// Trace shadow rays.
    pub shadows: bool,
}

/// The shading pass.
pub struct Shade {
    ctx: Context,
    pipeline: Pipeline,
    plain: Sampler,
    trilinear: Sampler,
    dummy_image: GpuEnvMap,
    dummy_buffer: Buffer,
}

impl Shade {
    /// Builds the pipeline.
    pub fn new(ctx: &Context) -> Result<Shade> {
        let dummy_buffer = Buffer::storage(ctx, "shade: unused buffer", &[0.0f32; 4])?;
        Ok(Shade {
            ctx: ctx.clone(),
            pipeline: Pipeline::fullscreen(
                ctx,
                ShaderId::FullscreenVert,
                ShaderId::Shade,
                &[FORMAT],
            )?,
            plain: Sampler::linear_clamp(ctx, "shade sampler")?,
            trilinear: Sampler::trilinear_clamp(ctx, "shade trilinear sampler")?,
            dummy_image: GpuEnvMap::upload(
                ctx,
                &EnvMap::new(Mapping::LatLong, 1, 1, vec![[0.0; 3]]),
            )?,
            dummy_buffer,
        })
    }

    /// Shades `gbuf`; returns the frame (linear RGB) and its GPU time ("shade").
    pub fn run(
        &self,
        gbuf: &GBuffer,
        inputs: &ShadeInputs<'_>,
    ) -> Result<(GpuEnvMap, Vec<Timing>)> {
        let coeffs = match inputs.sh {
            Some(c) if !c.is_empty() => {
                let data: Vec<[f32; 4]> = c
                    .iter()
                    .map(|v| [v[0] as f32, v[1] as f32, v[2] as f32, 0.0])
                    .collect();
                Some(Buffer::storage(&self.ctx, "shade SH coefficients", &data)?)
            }
            _ => None,
        };
        let frame = target(&self.ctx, "shaded frame", gbuf.width, gbuf.height)?;
        let dp = inputs.dp.unwrap_or(&self.dummy_image);
        let mc = inputs.mc.map(|m| m.0).unwrap_or(&self.dummy_image);
        let set = DescriptorSet::new(
            &self.ctx,
            &self.pipeline,
            &[
                (
                    binding::SHADE_NORMAL,
                    Bind::Sampled(&gbuf.normal.image, &self.plain, false),
                ),
                (
                    binding::SHADE_VIEW,
                    Bind::Sampled(&gbuf.view.image, &self.plain, false),
                ),
                (binding::SHADE_OBJECTS, Bind::Buffer(&gbuf.objects)),
                (
                    binding::SHADE_COEFFS,
                    Bind::Buffer(coeffs.as_ref().unwrap_or(&self.dummy_buffer)),
                ),
                (
                    binding::SHADE_ENV,
                    Bind::Sampled(&inputs.env.image, &self.plain, false),
                ),
                (
                    binding::SHADE_POSITION,
                    Bind::Sampled(&gbuf.position.image, &self.plain, false),
                ),
                (
                    binding::SHADE_DP,
                    Bind::Sampled(&dp.image, &self.trilinear, false),
                ),
                (
                    binding::SHADE_PREFILTERED,
                    Bind::Buffer(inputs.prefiltered.unwrap_or(&self.dummy_buffer)),
                ),
                (
                    binding::SHADE_MC,
                    Bind::Sampled(&mc.image, &self.plain, false),
                ),
            ],
        )?;
        let push = ShadePush {
            world_to_file: mat3_rows(inputs.orientation.world_to_file()),
            env_size: [inputs.env.width, inputs.env.height],
            env_mapping: inputs.env.mapping.id(),
            count: gbuf.count,
            dp_size: dp.width,
            max_lod: (dp.mips() - 1) as f32,
            shadows: inputs.shadows as u32,
            mc_samples: inputs.mc.map(|m| m.1).unwrap_or(0),
        };
        let mut spans = Spans::new(&self.ctx, 1)?;
        self.ctx.submit_and_wait("shading", |cmd| {
            spans.reset(cmd);
            record_fullscreen(
                &self.ctx,
                cmd,
                &mut spans,
                "shade",
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
