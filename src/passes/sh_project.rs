//! SH projection of an environment map on the GPU (Ramamoorthi & Hanrahan 2001): coefficients
//! to any band up to `SH_MAX_LMAX`, and R&H's 4×4 irradiance matrices.

use super::map::GpuEnvMap;
use crate::abi::{
    binding,
    push::{ShProjectPush, ShReducePush},
    ShaderId, SH_MAX_LMAX, SH_RUN, SH_WORKGROUP,
};
use crate::error::{Error, Result};
use crate::gpu::{mat3_rows, Bind, Buffer, Context, Pipeline, Recorder, Sampler, Timing, Usage};
use crate::math::sh;
use crate::passes::testing::poison::{self, PassId};
use crate::{Mapping, Orientation};
use ash::vk;
use gpu_allocator::MemoryLocation;
use std::sync::OnceLock;

/// SH coefficients of radiance, RGB, flat index k = l(l+1)+m.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct ShCoefficients {
    /// Highest band.
    pub lmax: u32,
    /// (lmax+1)² RGB coefficients.
    pub coeffs: Vec<[f64; 3]>,
}

/// What `envlight sh` writes (documented in docs/formats.md): the order, the RGB coefficients in
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
    /// Coefficients of bands up to `lmax` from flat RGB f32 triples (what the projection
    /// writes).
    pub fn from_f32(lmax: u32, flat: &[f32]) -> ShCoefficients {
        let coeffs = flat
            .chunks_exact(3)
            .take(sh::count(lmax))
            .map(|c| [c[0] as f64, c[1] as f64, c[2] as f64])
            .collect();
        ShCoefficients { lmax, coeffs }
    }

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

/// Whether a pass (the SH projection, the shade pass) may use subgroup operations.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Subgroups {
    /// Use them where the device has them (the SH projection: arithmetic in compute
    /// shaders; the shade pass: vote in fragment shaders).
    #[default]
    Auto,
    /// Never (the SH projection: the shared-memory tree; the shade pass: each lane ends its
    /// walks alone), e.g. to test the fallback.
    Off,
}

/// Projection pipelines: one per band and mapping.
const PROJECT_VARIANTS: usize = (SH_MAX_LMAX as usize + 1) * 4;

/// The projection pass.
pub struct ShProjector {
    ctx: Context,
    /// One projection pipeline per band and mapping (specialisation constants), built on first use.
    project: [OnceLock<Pipeline>; PROJECT_VARIANTS],
    project_shader: ShaderId,
    /// The same without the disc rim rule, for lat-long and cube maps.
    grid_shader: ShaderId,
    /// Lat-long maps to l = 2, with band and mapping fixed at compile time.
    latlong2_shader: ShaderId,
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
        let (p, grid, latlong2, r) = if use_sg {
            (
                ShaderId::ShProjectSubgroup,
                ShaderId::ShProjectGridSubgroup,
                ShaderId::ShProjectLatLong2Subgroup,
                ShaderId::ShReduceSubgroup,
            )
        } else {
            (
                ShaderId::ShProjectShared,
                ShaderId::ShProjectGridShared,
                ShaderId::ShProjectLatLong2Shared,
                ShaderId::ShReduceShared,
            )
        };
        Ok(ShProjector {
            ctx: ctx.clone(),
            project: std::array::from_fn(|_| OnceLock::new()),
            project_shader: p,
            grid_shader: grid,
            latlong2_shader: latlong2,
            reduce: Pipeline::compute(ctx, r, &[SH_WORKGROUP])?,
            sampler: Sampler::linear_clamp(ctx, "sh sampler")?,
            subgroups: use_sg,
        })
    }

    /// Texels per invocation (see `glsl/sh_project.comp`).
    fn run_length(mapping: Mapping) -> u32 {
        match mapping {
            Mapping::LatLong | Mapping::Cube => SH_RUN,
            Mapping::Angular | Mapping::DualParaboloid => 1,
        }
    }

    fn project_pipeline(&self, lmax: u32, mapping: Mapping) -> Result<&Pipeline> {
        Pipeline::compute_once(
            &self.project[(lmax + (SH_MAX_LMAX + 1) * mapping.id()) as usize],
            &self.ctx,
            match mapping {
                Mapping::LatLong if lmax == 2 => self.latlong2_shader,
                Mapping::LatLong | Mapping::Cube => self.grid_shader,
                Mapping::Angular | Mapping::DualParaboloid => self.project_shader,
            },
            &[SH_WORKGROUP, lmax, mapping.id(), Self::run_length(mapping)],
        )
    }

    /// Builds the projection pipeline for band `lmax` of `mapping` maps now rather than at
    /// the first [`ShProjector::record`] that needs it: from another thread while a map
    /// loads or uploads (it takes tens of milliseconds on lavapipe, which compiles SPIR-V on
    /// every run), or before an engine's frame.
    pub fn prepare(&self, lmax: u32, mapping: Mapping) -> Result<()> {
        if lmax > SH_MAX_LMAX {
            return Err(Error::Invalid(format!(
                "SH order {lmax} is above the maximum, {SH_MAX_LMAX}"
            )));
        }
        self.project_pipeline(lmax, mapping).map(|_| ())
    }

    /// Whether this projector uses subgroup operations.
    pub fn uses_subgroups(&self) -> bool {
        self.subgroups
    }

    /// Bytes of the coefficients of bands up to `lmax` as [`ShProjector::record`] writes
    /// them: (lmax+1)² RGB triples of f32.
    pub fn output_bytes(lmax: u32) -> u64 {
        sh::count(lmax) as u64 * 12
    }

    /// Records the projection of `map`, whose file is oriented by `orientation`, up to band
    /// `lmax` in the world frame, into a host-visible buffer; read the coefficients from the
    /// returned [`ShReadback`] once the command buffer has completed (keep it until then).
    /// Spans: "sh project", "sh reduce".
    pub fn record(
        &self,
        rec: &mut Recorder,
        map: &GpuEnvMap,
        lmax: u32,
        orientation: &Orientation,
    ) -> Result<ShReadback> {
        let buffer = Buffer::new(
            &self.ctx,
            "sh readback",
            ShProjector::output_bytes(lmax.min(SH_MAX_LMAX)),
            vk::BufferUsageFlags::TRANSFER_DST,
            MemoryLocation::GpuToCpu,
        )?;
        self.record_into(rec, map, lmax, orientation, &buffer)?;
        rec.use_buffer(&buffer, Usage::HostRead);
        Ok(ShReadback { buffer, lmax })
    }

    /// [`ShProjector::record`] into a buffer of the caller's, for GPU work that reads the
    /// coefficients next: they land at the start of `out` (TRANSFER_DST usage, at least
    /// [`ShProjector::output_bytes`]), flat index k = l(l+1)+m, RGB f32.
    pub fn record_into(
        &self,
        rec: &mut Recorder,
        map: &GpuEnvMap,
        lmax: u32,
        orientation: &Orientation,
        out: &Buffer,
    ) -> Result<()> {
        if lmax > SH_MAX_LMAX {
            return Err(Error::Invalid(format!(
                "SH order {lmax} is above the maximum, {SH_MAX_LMAX}"
            )));
        }
        let rule_error = sh::rule_error(map.mapping, map.width, map.height, lmax);
        if rule_error > sh::RULE_TOLERANCE {
            return Err(Error::Invalid(format!(
                "the {} x {} {} map is too coarse for SH order {lmax}: its texels are too large \
                 for the per-texel quadrature, which would be off by {:.1}% of L00 (limit \
                 {:.1}%); convert it to a larger size first (envlight convert --size)",
                map.width,
                map.height,
                map.mapping.name(),
                rule_error * 100.0,
                sh::RULE_TOLERANCE * 100.0
            )));
        }
        let n = sh::count(lmax) as u32;
        let row_bytes = ShProjector::output_bytes(lmax);
        assert!(out.size() >= row_bytes, "the SH output buffer is too small");
        let texels = map.width * map.height * map.mapping.layers();
        let max = self.ctx.info().max_workgroup_count;
        let run = Self::run_length(map.mapping);
        let groups = texels.div_ceil(SH_WORKGROUP * run);
        let (gx, gy) = grid(groups, max);
        // Rows of partial sums at each level of the tree, down to one.
        let mut levels = vec![gx * gy];
        while *levels.last().unwrap_or(&1) > 1 {
            let g = levels.last().copied().unwrap_or(1).div_ceil(SH_WORKGROUP);
            let (x, y) = grid(g, max);
            levels.push(x * y);
        }
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
        let push = ShProjectPush {
            file_to_world: mat3_rows(orientation.checked_world_to_file()?.transpose()),
            size: [map.width, map.height],
            mapping: map.mapping.id(),
            lmax,
            texels,
            pad: [0; 3],
        };
        let pipeline = self.project_pipeline(lmax, map.mapping)?;
        rec.span("sh project", |rec| {
            rec.dispatch(
                pipeline,
                &[
                    (
                        binding::SH_SRC,
                        Bind::Sampled(&map.image, &self.sampler, false),
                    ),
                    (binding::SH_PARTIALS, Bind::Buffer(&a)),
                ],
                &push,
                [gx, gy, 1],
            )
        })?;
        rec.span("sh reduce", |rec| {
            for (lvl, rows) in levels.iter().enumerate().take(levels.len() - 1) {
                let (from, to) = if lvl % 2 == 0 { (&a, &b) } else { (&b, &a) };
                let (x, y) = grid(rows.div_ceil(SH_WORKGROUP), max);
                rec.dispatch(
                    &self.reduce,
                    &[
                        (binding::SH_REDUCE_IN, Bind::Buffer(from)),
                        (binding::SH_REDUCE_OUT, Bind::Buffer(to)),
                    ],
                    &ShReducePush {
                        rows: *rows,
                        coeffs: n,
                        pad: [0; 2],
                    },
                    [x, y, 1],
                )?;
            }
            Ok(())
        })?;
        let result = if (levels.len() - 1) % 2 == 0 { &a } else { &b };
        let f = poison::Floats::sh(0, 3 * n, 3, n);
        poison::buffer(rec, PassId::ShProject, result, f)?;
        rec.copy_buffer(result, out, row_bytes);
        rec.keep((a, b));
        Ok(())
    }

    /// Projects `map` up to band `lmax`; returns the coefficients and the GPU time.
    pub fn run(&self, map: &GpuEnvMap, lmax: u32) -> Result<(ShCoefficients, Vec<Timing>)> {
        self.run_oriented(map, lmax, &Orientation::default())
    }

    /// Projects `map`, whose file is oriented by `orientation`, in the world frame, and waits.
    pub fn run_oriented(
        &self,
        map: &GpuEnvMap,
        lmax: u32,
        orientation: &Orientation,
    ) -> Result<(ShCoefficients, Vec<Timing>)> {
        let (readback, timings) = self.ctx.run("projecting onto SH", |rec| {
            self.record(rec, map, lmax, orientation)
        })?;
        Ok((readback.read(), timings))
    }
}

/// The coefficients [`ShProjector::record`] writes, in a host-visible buffer.
pub struct ShReadback {
    buffer: Buffer,
    lmax: u32,
}

impl ShReadback {
    /// The coefficients; valid once the recorded work has completed.
    pub fn read(&self) -> ShCoefficients {
        ShCoefficients::from_f32(self.lmax, &self.buffer.read(sh::count(self.lmax) * 3))
    }
}
