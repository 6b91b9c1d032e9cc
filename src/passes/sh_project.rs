//! SH projection of an environment map on the GPU (Ramamoorthi & Hanrahan 2001): coefficients
//! to any band up to `SH_MAX_LMAX`, and R&H's 4×4 irradiance matrices. A lat-long map's
//! projection separates (`glsl/sh_rows.comp`, `glsl/sh_latlong.comp`): per row its Fourier
//! sums in φ, then a sum over rows, 2·lmax + 1 multiply-adds a texel and channel; the other
//! mappings take the basis at each texel's quadrature nodes (`glsl/sh_project.comp`). Both
//! end in the same tree of partial sums and match `math::sh::project` node for node.

use super::map::GpuEnvMap;
use crate::abi::{
    binding,
    push::{ShLatLongPush, ShProjectPush, ShReducePush},
    ShaderId, SH_MAX_LMAX, SH_RUN, SH_WORKGROUP,
};
use crate::error::{Error, Result};
use crate::gpu::{mat3_rows, Bind, Buffer, Context, Pipeline, Recorder, Sampler, Timed, Usage};
use crate::math::sh;
use crate::passes::testing::poison::{self, PassId};
use crate::{Mapping, Orientation};
use ash::vk;
use gpu_allocator::MemoryLocation;
use std::sync::Arc;
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
/// Pipelines of the lat-long path: one per band.
const BANDS: usize = SH_MAX_LMAX as usize + 1;

/// The projection pass.
pub struct ShProjector {
    ctx: Context,
    /// One projection pipeline per band and mapping (specialisation constants), built on first
    /// use: angular, cube and paraboloid maps.
    project: [OnceLock<Pipeline>; PROJECT_VARIANTS],
    project_shader: ShaderId,
    /// The same without the disc rim rule, for cube maps.
    grid_shader: ShaderId,
    /// Lat-long maps: the rows' Fourier sums and their sum over rows, per band.
    rows: [OnceLock<Pipeline>; BANDS],
    rows_shader: ShaderId,
    latlong: [OnceLock<Pipeline>; BANDS],
    latlong_shader: ShaderId,
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
        let (p, grid, rows, latlong, r) = if use_sg {
            (
                ShaderId::ShProjectSubgroup,
                ShaderId::ShProjectGridSubgroup,
                ShaderId::ShRowsSubgroup,
                ShaderId::ShLatLongSubgroup,
                ShaderId::ShReduceSubgroup,
            )
        } else {
            (
                ShaderId::ShProjectShared,
                ShaderId::ShProjectGridShared,
                ShaderId::ShRowsShared,
                ShaderId::ShLatLongShared,
                ShaderId::ShReduceShared,
            )
        };
        Ok(ShProjector {
            ctx: ctx.clone(),
            project: std::array::from_fn(|_| OnceLock::new()),
            project_shader: p,
            grid_shader: grid,
            rows: std::array::from_fn(|_| OnceLock::new()),
            rows_shader: rows,
            latlong: std::array::from_fn(|_| OnceLock::new()),
            latlong_shader: latlong,
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

    /// The band the projection of a `mapping` map up to `lmax` runs at: `lmax`, but band 1
    /// for band 0 of the per-texel path, whose first coefficient is the same sum in the same
    /// order. llvmpipe runs the band-0 specialisation of that shader 1.6–4× slower than band
    /// 1, and elsewhere three more sums cost little next to the texels' reads and
    /// quadratures.
    fn run_lmax(lmax: u32, mapping: Mapping) -> u32 {
        match mapping {
            Mapping::LatLong => lmax,
            _ => lmax.max(1),
        }
    }

    fn project_pipeline(&self, lmax: u32, mapping: Mapping) -> Result<&Pipeline> {
        assert_ne!(
            mapping,
            Mapping::LatLong,
            "lat-long maps take the separable path"
        );
        Pipeline::compute_once(
            &self.project[(lmax + (SH_MAX_LMAX + 1) * mapping.id()) as usize],
            &self.ctx,
            match mapping {
                Mapping::LatLong | Mapping::Cube => self.grid_shader,
                Mapping::Angular | Mapping::DualParaboloid => self.project_shader,
            },
            &[SH_WORKGROUP, lmax, mapping.id(), Self::run_length(mapping)],
        )
    }

    /// Invocations a row in the rows' pass: one subgroup where subgroups sum the row (each of
    /// its 2·lmax + 1 sums is then one subgroup add, with no shared memory to wait on), else
    /// SH_WORKGROUP.
    fn rows_workgroup(&self) -> u32 {
        match self.subgroups {
            true => self.ctx.info().subgroup_size.clamp(1, SH_WORKGROUP),
            false => SH_WORKGROUP,
        }
    }

    /// The lat-long path's pipelines for band `lmax`: the rows' sums, and their sum.
    fn latlong_pipelines(&self, lmax: u32) -> Result<(&Pipeline, &Pipeline)> {
        let spec = [SH_WORKGROUP, lmax];
        Ok((
            Pipeline::compute_once(
                &self.rows[lmax as usize],
                &self.ctx,
                self.rows_shader,
                &[self.rows_workgroup(), lmax],
            )?,
            Pipeline::compute_once(
                &self.latlong[lmax as usize],
                &self.ctx,
                self.latlong_shader,
                &spec,
            )?,
        ))
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
        if mapping == Mapping::LatLong {
            return self.latlong_pipelines(lmax).map(|_| ());
        }
        self.project_pipeline(Self::run_lmax(lmax, mapping), mapping)
            .map(|_| ())
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
        let row_bytes = ShProjector::output_bytes(lmax);
        assert!(out.size() >= row_bytes, "the SH output buffer is too small");
        let file_to_world = orientation.checked_world_to_file()?.transpose();
        let run = Self::run_lmax(lmax, map.mapping);
        let n = sh::count(run) as u32;
        let partials = rec.span("sh project", |rec| {
            if map.mapping == Mapping::LatLong {
                self.record_latlong(rec, map, run, file_to_world)
            } else {
                self.record_texels(rec, map, run, file_to_world)
            }
        })?;
        let result = self.record_reduce(rec, partials, run)?;
        let f = poison::Floats::sh(0, 3 * n, 3, n);
        poison::buffer(rec, PassId::ShProject, &result, f)?;
        rec.copy_buffer(&result, out, row_bytes);
        Ok(())
    }

    /// Rows of partial sums, (lmax + 1)² RGB triples each, as the first level of the tree (a
    /// scratch buffer of the recording).
    fn partials(rec: &mut Recorder, rows: u32, lmax: u32) -> Result<Arc<Buffer>> {
        rec.scratch(
            "sh partials",
            ShProjector::output_bytes(lmax) * rows as u64,
            vk::BufferUsageFlags::STORAGE_BUFFER | vk::BufferUsageFlags::TRANSFER_SRC,
        )
    }

    /// Records the per-texel projection (angular, cube and paraboloid maps): a partial sum per
    /// workgroup of SH_WORKGROUP·run texels. Returns the partials and their count.
    fn record_texels(
        &self,
        rec: &mut Recorder,
        map: &GpuEnvMap,
        lmax: u32,
        file_to_world: glam::DMat3,
    ) -> Result<(Arc<Buffer>, u32)> {
        let texels = map.width * map.height * map.mapping.layers();
        let max = self.ctx.info().max_workgroup_count;
        let groups = texels.div_ceil(SH_WORKGROUP * Self::run_length(map.mapping));
        let (gx, gy) = grid(groups, max);
        let partials = Self::partials(rec, gx * gy, lmax)?;
        let push = ShProjectPush {
            file_to_world: mat3_rows(file_to_world),
            size: [map.width, map.height],
            mapping: map.mapping.id(),
            lmax,
            texels,
            pad: [0; 3],
        };
        let pipeline = self.project_pipeline(lmax, map.mapping)?;
        rec.dispatch(
            pipeline,
            &[
                (
                    binding::SH_SRC,
                    Bind::Sampled(&map.image, &self.sampler, false),
                ),
                (binding::SH_PARTIALS, Bind::Buffer(&partials)),
            ],
            &push,
            [gx, gy, 1],
        )?;
        Ok((partials, gx * gy))
    }

    /// Records the separable projection of a lat-long map: the rows' Fourier sums (a
    /// workgroup a row), then their sum over rows, turned into the world frame (a partial sum
    /// per workgroup of SH_WORKGROUP rows). Returns the partials and their count (the rows'
    /// sums are a scratch buffer the recorder keeps).
    fn record_latlong(
        &self,
        rec: &mut Recorder,
        map: &GpuEnvMap,
        lmax: u32,
        file_to_world: glam::DMat3,
    ) -> Result<(Arc<Buffer>, u32)> {
        let (w, h) = (map.width, map.height);
        let max = self.ctx.info().max_workgroup_count;
        let sums = rec.scratch(
            "sh row sums",
            (h * (2 * lmax + 1) * 12) as u64,
            vk::BufferUsageFlags::STORAGE_BUFFER,
        )?;
        let (rows_pipeline, latlong_pipeline) = self.latlong_pipelines(lmax)?;
        let (rotation, parity) = latlong_rotation(file_to_world);
        let push = ShLatLongPush {
            rotation: mat3_rows(rotation),
            size: [w, h],
            lmax,
            parity: parity as u32,
        };
        let (rx, ry) = grid(h, max);
        rec.dispatch(
            rows_pipeline,
            &[
                (
                    binding::SH_ROWS_SRC,
                    Bind::Sampled(&map.image, &self.sampler, false),
                ),
                (binding::SH_ROWS_OUT, Bind::Buffer(&sums)),
            ],
            &push,
            [rx, ry, 1],
        )?;
        let (gx, gy) = grid(h.div_ceil(SH_WORKGROUP), max);
        let partials = Self::partials(rec, gx * gy, lmax)?;
        rec.dispatch(
            latlong_pipeline,
            &[
                (binding::SH_LATLONG_ROWS, Bind::Buffer(&sums)),
                (binding::SH_LATLONG_PARTIALS, Bind::Buffer(&partials)),
            ],
            &push,
            [gx, gy, 1],
        )?;
        Ok((partials, gx * gy))
    }

    /// Records the pairwise tree over `rows` partial sums of bands up to `lmax`, down to one
    /// row: the buffer holding it. Span: "sh reduce" (empty where one row is all there is).
    fn record_reduce(
        &self,
        rec: &mut Recorder,
        (first, rows): (Arc<Buffer>, u32),
        lmax: u32,
    ) -> Result<Arc<Buffer>> {
        let max = self.ctx.info().max_workgroup_count;
        let n = sh::count(lmax) as u32;
        // Rows of partial sums at each level of the tree, down to one.
        let mut levels = vec![rows];
        while *levels.last().unwrap_or(&1) > 1 {
            let g = levels.last().copied().unwrap_or(1).div_ceil(SH_WORKGROUP);
            let (x, y) = grid(g, max);
            levels.push(x * y);
        }
        let second = Self::partials(rec, levels.get(1).copied().unwrap_or(1), lmax)?;
        let (a, b) = (first, second);
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
        Ok(if (levels.len() - 1) % 2 == 0 { a } else { b })
    }

    /// Projects `map` up to band `lmax`; returns the coefficients and the GPU time.
    pub fn run(&self, map: &GpuEnvMap, lmax: u32) -> Result<Timed<ShCoefficients>> {
        self.run_oriented(map, lmax, &Orientation::default())
    }

    /// Projects `map`, whose file is oriented by `orientation`, in the world frame, and waits.
    pub fn run_oriented(
        &self,
        map: &GpuEnvMap,
        lmax: u32,
        orientation: &Orientation,
    ) -> Result<Timed<ShCoefficients>> {
        let Timed {
            value: readback,
            timings,
        } = self.ctx.run("projecting onto SH", |rec| {
            self.record(rec, map, lmax, orientation)
        })?;
        Ok(Timed::new(readback.read(), timings))
    }
}

/// The rotation that turns coefficients in the lat-long's polar frame P (pole along the file's
/// +Y, φ = 2πu: P·f = (−f.z, f.x, f.y)) into the world frame, and whether the odd bands flip
/// first: c = M(Qᵀ)·c' for Q = P·file_to_worldᵀ, and for an improper Q = −R (a flipped file,
/// or P itself, which is a reflection) c = M(−Qᵀ)·((−1)^l c'), M(−Qᵀ) a proper rotation's.
fn latlong_rotation(file_to_world: glam::DMat3) -> (glam::DMat3, bool) {
    // Pᵀ, columns: P's rows (0, 0, −1), (1, 0, 0), (0, 1, 0).
    let pt = glam::DMat3::from_cols(
        glam::DVec3::new(0.0, 0.0, -1.0),
        glam::DVec3::new(1.0, 0.0, 0.0),
        glam::DVec3::new(0.0, 1.0, 0.0),
    );
    let qt = file_to_world * pt;
    if qt.determinant() < 0.0 {
        (-qt, true)
    } else {
        (qt, false)
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
