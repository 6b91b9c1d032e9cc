//! SH projection of an environment map on the GPU (Ramamoorthi & Hanrahan 2001): coefficients
//! to any band up to [`SH_MAX_LMAX`], and R&H's 4×4 irradiance matrices.

use crate::error::{Error, Result};
use crate::gpu::barrier::{cmd_memory_barrier, memory_barrier, Usage};
use crate::gpu::layout::{binding, SH_MAX_LMAX, SH_WORKGROUP};
use crate::gpu::pipeline::{Bind, DescriptorSet, Pipeline};
use crate::gpu::shaders::ShaderId;
use crate::gpu::timing::Spans;
use crate::gpu::{mat3_rows, Buffer, Context, GpuEnvMap, Sampler, Timing};
use crate::math::sh;
use crate::Orientation;
use ash::vk;
use gpu_allocator::MemoryLocation;

/// Push constants of `glsl/sh_project.comp`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, bytemuck::Pod, bytemuck::Zeroable)]
pub struct ShProjectPush {
    /// Rows of the file → world matrix (the inverse of [`crate::Orientation::world_to_file`]).
    pub file_to_world: [[f32; 4]; 3],
    /// Layer size.
    pub size: [u32; 2],
    /// Mapping id.
    pub mapping: u32,
    /// Highest band.
    pub lmax: u32,
    /// Texels in all layers.
    pub texels: u32,
    /// Padding.
    pub pad: [u32; 3],
}

/// Push constants of `glsl/sh_reduce.comp`.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, bytemuck::Pod, bytemuck::Zeroable)]
pub struct ShReducePush {
    /// Rows of partial sums in the input.
    pub rows: u32,
    /// Coefficients per row.
    pub coeffs: u32,
    /// Padding.
    pub pad: [u32; 2],
}

/// SH coefficients of radiance, RGB, flat index k = l(l+1)+m.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct ShCoefficients {
    /// Highest band.
    pub lmax: u32,
    /// (lmax+1)² RGB coefficients.
    pub coeffs: Vec<[f64; 3]>,
}

/// What `envlight sh` writes (documented in the README): the order, the RGB coefficients in
/// flat index k = l(l+1)+m, and R&H's 4×4 irradiance matrix per channel (needs order ≥ 2).
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct ShJson {
    /// Highest band l.
    pub order: u32,
    /// (order+1)² RGB radiance coefficients.
    pub coefficients: Vec<[f64; 3]>,
    /// M per channel such that E(n) = nᵀMn with n = (x, y, z, 1); absent below order 2.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub irradiance_matrices: Option<IrradianceMatrices>,
}

/// R&H's matrices for the three channels.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct IrradianceMatrices {
    /// Red.
    pub r: [[f64; 4]; 4],
    /// Green.
    pub g: [[f64; 4]; 4],
    /// Blue.
    pub b: [[f64; 4]; 4],
}

impl ShCoefficients {
    /// The JSON document of `envlight sh`.
    pub fn to_json(&self) -> ShJson {
        ShJson {
            order: self.lmax,
            coefficients: self.coeffs.clone(),
            irradiance_matrices: (self.lmax >= 2).then(|| {
                let [r, g, b] = self.irradiance_matrices();
                IrradianceMatrices { r, g, b }
            }),
        }
    }

    /// R&H's irradiance matrix M per channel (R, G, B): E(n) = nᵀMn with n = (x, y, z, 1).
    /// Needs lmax ≥ 2.
    pub fn irradiance_matrices(&self) -> [[[f64; 4]; 4]; 3] {
        assert!(
            self.lmax >= 2,
            "the irradiance matrix needs bands up to l = 2"
        );
        [0, 1, 2].map(|c| {
            let l: Vec<f64> = self.coeffs[..9].iter().map(|v| v[c]).collect();
            sh::irradiance_matrix(&l)
        })
    }
}

/// Whether the projection may use subgroup operations.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Subgroups {
    /// Use them where the device has subgroup arithmetic in compute shaders.
    #[default]
    Auto,
    /// Never (the shared-memory tree), e.g. to test the fallback.
    Off,
}

/// The projection pass.
pub struct ShProjector {
    ctx: Context,
    project: Pipeline,
    reduce: Pipeline,
    sampler: Sampler,
    subgroups: bool,
}

fn grid(groups: u32, max: u32) -> (u32, u32) {
    let x = groups.clamp(1, max.min(65535));
    (x, groups.div_ceil(x).max(1))
}

impl ShProjector {
    /// Builds the pipelines (subgroup variants where allowed and available).
    pub fn new(ctx: &Context, subgroups: Subgroups) -> Result<ShProjector> {
        let use_sg = subgroups == Subgroups::Auto && ctx.info().subgroup_arithmetic;
        let (p, r) = if use_sg {
            (ShaderId::ShProjectSubgroup, ShaderId::ShReduceSubgroup)
        } else {
            (ShaderId::ShProjectShared, ShaderId::ShReduceShared)
        };
        Ok(ShProjector {
            ctx: ctx.clone(),
            project: Pipeline::compute(ctx, p, &[SH_WORKGROUP])?,
            reduce: Pipeline::compute(ctx, r, &[SH_WORKGROUP])?,
            sampler: Sampler::linear_clamp(ctx, "sh sampler")?,
            subgroups: use_sg,
        })
    }

    /// Whether this projector uses subgroup operations.
    pub fn uses_subgroups(&self) -> bool {
        self.subgroups
    }

    /// Projects `map` up to band `lmax`; returns the coefficients and the GPU time.
    pub fn run(&self, map: &GpuEnvMap, lmax: u32) -> Result<(ShCoefficients, Vec<Timing>)> {
        self.run_oriented(map, lmax, &Orientation::default())
    }

    /// Projects `map`, whose file is oriented by `orientation`, in the world frame.
    pub fn run_oriented(
        &self,
        map: &GpuEnvMap,
        lmax: u32,
        orientation: &Orientation,
    ) -> Result<(ShCoefficients, Vec<Timing>)> {
        if lmax > SH_MAX_LMAX {
            return Err(Error::Invalid(format!(
                "SH order {lmax} is above the maximum, {SH_MAX_LMAX}"
            )));
        }
        let n = sh::count(lmax) as u32;
        let texels = map.width * map.height * map.mapping.layers();
        let max = self.ctx.info().max_workgroup_count;
        let groups = texels.div_ceil(SH_WORKGROUP);
        let (gx, gy) = grid(groups, max);
        // Rows of partial sums at each level of the tree, down to one.
        let mut levels = vec![gx * gy];
        while *levels.last().unwrap_or(&1) > 1 {
            let g = levels.last().copied().unwrap_or(1).div_ceil(SH_WORKGROUP);
            let (x, y) = grid(g, max);
            levels.push(x * y);
        }
        let row_bytes = (n * 3 * 4) as u64;
        let mk = |name: &str| {
            Buffer::new(
                &self.ctx,
                name,
                row_bytes * levels[0] as u64,
                vk::BufferUsageFlags::STORAGE_BUFFER | vk::BufferUsageFlags::TRANSFER_SRC,
                MemoryLocation::GpuOnly,
            )
        };
        let (a, b) = (mk("sh partials A")?, mk("sh partials B")?);
        let readback = Buffer::new(
            &self.ctx,
            "sh readback",
            row_bytes,
            vk::BufferUsageFlags::TRANSFER_DST,
            MemoryLocation::GpuToCpu,
        )?;
        let project_set = DescriptorSet::new(
            &self.ctx,
            &self.project,
            &[
                (
                    binding::SH_SRC,
                    Bind::Sampled(&map.image, &self.sampler, false),
                ),
                (binding::SH_PARTIALS, Bind::Buffer(&a)),
            ],
        )?;
        let ab = DescriptorSet::new(
            &self.ctx,
            &self.reduce,
            &[
                (binding::SH_REDUCE_IN, Bind::Buffer(&a)),
                (binding::SH_REDUCE_OUT, Bind::Buffer(&b)),
            ],
        )?;
        let ba = DescriptorSet::new(
            &self.ctx,
            &self.reduce,
            &[
                (binding::SH_REDUCE_IN, Bind::Buffer(&b)),
                (binding::SH_REDUCE_OUT, Bind::Buffer(&a)),
            ],
        )?;
        let push = ShProjectPush {
            file_to_world: mat3_rows(orientation.world_to_file().transpose()),
            size: [map.width, map.height],
            mapping: map.mapping.id(),
            lmax,
            texels,
            pad: [0; 3],
        };
        let mut spans = Spans::new(&self.ctx, 2)?;
        let d = self.ctx.device();
        let result_in_a = (levels.len() - 1) % 2 == 0;
        self.ctx.submit_and_wait("projecting onto SH", |cmd| {
            spans.reset(cmd);
            let span = spans.begin(cmd, "sh project");
            self.project.bind(cmd, Some(&project_set), &push);
            // SAFETY: cmd is recording with the compute pipeline bound.
            unsafe { d.cmd_dispatch(cmd, gx, gy, 1) };
            spans.end(cmd, span);
            let span = spans.begin(cmd, "sh reduce");
            for (lvl, rows) in levels.iter().enumerate().take(levels.len() - 1) {
                cmd_memory_barrier(
                    d,
                    cmd,
                    memory_barrier(Usage::ComputeWrite, Usage::ComputeRead),
                );
                let set = if lvl % 2 == 0 { &ab } else { &ba };
                let (x, y) = grid(rows.div_ceil(SH_WORKGROUP), max);
                self.reduce.bind(
                    cmd,
                    Some(set),
                    &ShReducePush {
                        rows: *rows,
                        coeffs: n,
                        pad: [0; 2],
                    },
                );
                // SAFETY: as above.
                unsafe { d.cmd_dispatch(cmd, x, y, 1) };
            }
            spans.end(cmd, span);
            cmd_memory_barrier(
                d,
                cmd,
                memory_barrier(Usage::ComputeWrite, Usage::TransferSrc),
            );
            let src = if result_in_a { &a } else { &b };
            let region = vk::BufferCopy {
                src_offset: 0,
                dst_offset: 0,
                size: row_bytes,
            };
            // SAFETY: both buffers are live and large enough.
            unsafe { d.cmd_copy_buffer(cmd, src.raw(), readback.raw(), &[region]) };
            cmd_memory_barrier(d, cmd, memory_barrier(Usage::TransferDst, Usage::HostRead));
            Ok(())
        })?;
        let flat: Vec<f32> = readback.read((n * 3) as usize);
        let coeffs = flat
            .chunks_exact(3)
            .map(|c| [c[0] as f64, c[1] as f64, c[2] as f64])
            .collect();
        let timings = spans.read()?;
        Ok((ShCoefficients { lmax, coeffs }, timings))
    }
}
