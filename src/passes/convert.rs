//! Conversion of an environment map from any mapping to any other, at any resolution.

use crate::error::Result;
use crate::gpu::layout::WORKGROUP_2D;
use crate::gpu::pipeline::{Bind, DescriptorSet, Pipeline};
use crate::gpu::shaders::ShaderId;
use crate::gpu::{mat3_rows, Context, GpuEnvMap, Sampler, Timing};
use crate::math::{Mapping, Orientation};
use std::sync::OnceLock;

/// Push constants of `glsl/convert.comp` (std430 layout; size checked against the SPIR-V).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, bytemuck::Pod, bytemuck::Zeroable)]
pub struct ConvertPush {
    /// Rows of the world → file rotation/reflection (w unused).
    pub world_to_file: [[f32; 4]; 3],
    /// Source layer size.
    pub src_size: [u32; 2],
    /// Destination layer size.
    pub dst_size: [u32; 2],
    /// Source mapping id.
    pub src_mapping: u32,
    /// Destination mapping id.
    pub dst_mapping: u32,
    /// Samples per axis per output texel.
    pub ss: u32,
    /// Padding to 16 bytes.
    pub pad: u32,
}

/// Per-call options of [`Converter::run`].
#[derive(Clone, Copy, Debug)]
pub struct ConvertOptions {
    /// Output mapping.
    pub to: Mapping,
    /// Output size: lat-long width (height is half), angular side, cube face side, or
    /// paraboloid half side.
    pub size: u32,
    /// How the source file is oriented relative to the world frame.
    pub orientation: Orientation,
    /// Samples per axis per output texel; `None` picks it from the resolutions
    /// ([`Converter::supersampling`]).
    pub supersample: Option<u32>,
}

/// Texels that cover the sphere (those inside the disc for angular and paraboloid maps).
fn texels_on_sphere(m: Mapping, w: u32, h: u32) -> f64 {
    let n = w as f64 * h as f64;
    match m {
        Mapping::LatLong => n,
        Mapping::Angular => n * std::f64::consts::FRAC_PI_4,
        Mapping::Cube => 6.0 * n,
        Mapping::DualParaboloid => 2.0 * n * std::f64::consts::FRAC_PI_4,
    }
}

/// The conversion pass. Pipelines are built on first use, one per source kind.
pub struct Converter {
    ctx: Context,
    from_2d: OnceLock<Pipeline>,
    from_cube: OnceLock<Pipeline>,
    sampler: Sampler,
}

impl Converter {
    /// Prepares the pass (no pipeline is built until a run needs it).
    pub fn new(ctx: &Context) -> Result<Converter> {
        Ok(Converter {
            ctx: ctx.clone(),
            from_2d: OnceLock::new(),
            from_cube: OnceLock::new(),
            sampler: Sampler::linear_clamp(ctx, "convert sampler")?,
        })
    }

    fn pipeline(&self, cube: bool) -> Result<&Pipeline> {
        let (cell, id) = if cube {
            (&self.from_cube, ShaderId::ConvertCube)
        } else {
            (&self.from_2d, ShaderId::Convert2d)
        };
        if cell.get().is_none() {
            let p = Pipeline::compute(&self.ctx, id, &WORKGROUP_2D)?;
            let _ = cell.set(p);
        }
        Ok(cell.get().unwrap_or_else(|| unreachable!("set above")))
    }

    /// Samples per axis for an output texel: about two per source texel spacing, so that
    /// minification averages every source texel the footprint covers (1 when magnifying).
    pub fn supersampling(src: (Mapping, u32, u32), dst: (Mapping, u32, u32)) -> u32 {
        let ratio =
            (texels_on_sphere(src.0, src.1, src.2) / texels_on_sphere(dst.0, dst.1, dst.2)).sqrt();
        ((4.0 * ratio).ceil() as u32).clamp(1, 64)
    }

    /// Converts `src` to `opts.to` at `opts.size`; returns the new map and the GPU time.
    pub fn run(&self, src: &GpuEnvMap, opts: &ConvertOptions) -> Result<(GpuEnvMap, Vec<Timing>)> {
        self.run_into(src, opts, false)
    }

    /// As [`Converter::run`], into a map with a full MIP chain of which only level 0 is
    /// written (for [`crate::passes::mip::MipChain`] to fill).
    pub fn run_mipped(
        &self,
        src: &GpuEnvMap,
        opts: &ConvertOptions,
    ) -> Result<(GpuEnvMap, Vec<Timing>)> {
        self.run_into(src, opts, true)
    }

    fn run_into(
        &self,
        src: &GpuEnvMap,
        opts: &ConvertOptions,
        mips: bool,
    ) -> Result<(GpuEnvMap, Vec<Timing>)> {
        let (w, h) = opts.to.extent_for_size(opts.size);
        let name = format!("{} {}", opts.to.name(), opts.size);
        let dst = if mips {
            GpuEnvMap::with_mips(&self.ctx, &name, opts.to, w, h)?
        } else {
            GpuEnvMap::new(&self.ctx, &name, opts.to, w, h)?
        };
        let ss = opts
            .supersample
            .unwrap_or_else(|| {
                Converter::supersampling((src.mapping, src.width, src.height), (opts.to, w, h))
            })
            .max(1);
        let push = ConvertPush {
            world_to_file: mat3_rows(opts.orientation.world_to_file()),
            src_size: [src.width, src.height],
            dst_size: [w, h],
            src_mapping: src.mapping.id(),
            dst_mapping: opts.to.id(),
            ss,
            pad: 0,
        };
        let cube = src.mapping == Mapping::Cube;
        let pipeline = self.pipeline(cube)?;
        let set = DescriptorSet::new(
            &self.ctx,
            pipeline,
            &[
                (
                    crate::gpu::layout::binding::CONVERT_SRC,
                    Bind::Sampled(&src.image, &self.sampler, cube),
                ),
                (
                    crate::gpu::layout::binding::CONVERT_DST,
                    Bind::Storage(&dst.image),
                ),
            ],
        )?;
        let label = format!(
            "convert {} -> {} {w}x{h}",
            src.mapping.name(),
            opts.to.name()
        );
        let timings = dst.fill(&self.ctx, "converting a map", &label, pipeline, &set, &push)?;
        Ok((dst, timings))
    }
}
