//! The exact reference on the GPU (`glsl/exact_shade.comp`, float64 twin
//! [`crate::math::exact::ExactFilter::shade`]): the radiance a BRDF reflects at each query (a
//! surface normal and a view) under a map, unshadowed, as the sum over every texel of its
//! ∫ f·cos dω by the twin's rule, nothing sampled. What a report scores its techniques
//! against, for every pixel of a sphere at once: the twin costs 1.6–37 ms a pixel on two
//! cores, a 64² sphere 5–120 s a material.
//!
//! The pass writes a partial sum per query and workgroup ([`ExactShader::record`]); the
//! query's value is their sum, which [`ExactShader::sum`] takes in float64 (each partial holds
//! at most a workgroup's compensated sums). The lobes are prepared on the host
//! ([`crate::math::exact::gpu_lobe`]) as the twin prepares them.

use crate::abi::exact::{HORIZON_SHRINK, MAX_CELLS_PER_WIDTH};
use crate::abi::{binding, push::ExactShadePush, ShaderId};
use crate::error::{Error, Result};
use crate::gpu::{Bind, Buffer, Context, Pipeline, Recorder, Sampler, Timed, Usage};
use crate::math::brdf::Brdf;
use crate::math::exact::{gpu_lobe, PER_WIDTH};
use crate::math::mapping::Mapping;
use crate::passes::testing::poison::{self, Floats, PassId};
use crate::passes::GpuEnvMap;
use ash::vk;
use glam::{DMat3, DVec3};
use gpu_allocator::MemoryLocation;

/// vec4s a query's lobe takes in the queries' buffer.
pub const QUERY_VEC4S: usize = crate::abi::exact::QUERY_VEC4S as usize;
/// Invocations a workgroup.
const WORKGROUP: u32 = crate::abi::EXACT_WORKGROUP;
/// Texels an invocation sums where the device has no loop limit.
const RUN: u32 = 32;

/// The exact reference pass.
pub struct ExactShader {
    ctx: Context,
    pipeline: Pipeline,
    sampler: Sampler,
}

/// What [`ExactShader::record`] reads: a map with its texels' solid angles, and the queries'
/// lobes, all of one BRDF.
pub struct ExactInputs<'a> {
    /// The map.
    pub map: &'a GpuEnvMap,
    /// [`ExactShader::solid_angles`] of the map's mapping and size, uploaded.
    pub omega: &'a Buffer,
    /// The largest texel angular size (√Ω) in it.
    pub rho_max: f64,
    /// The queries' lobes, [`QUERY_VEC4S`] vec4 each ([`ExactShader::lobes`]), uploaded.
    pub lobes: &'a Buffer,
    /// How many.
    pub count: u32,
    /// The smallest scale among their texel rules (the last word of each lobe).
    pub scale_min: f64,
    /// Their BRDF (not the mirror).
    pub brdf: Brdf,
}

impl ExactShader {
    /// Builds the pipeline.
    pub fn new(ctx: &Context) -> Result<ExactShader> {
        Ok(ExactShader {
            ctx: ctx.clone(),
            pipeline: Pipeline::compute(ctx, ShaderId::ExactShade, &[WORKGROUP])?,
            sampler: Sampler::linear_clamp(ctx, "exact sampler")?,
        })
    }

    /// The solid angles the pass reads for a `mapping` map of `width` × `height`, as the twin
    /// takes them: a lat-long's one a row, other mappings' one a texel of a layer
    /// ([`Mapping::texel_solid_angles`], the same for every layer).
    pub fn solid_angles(mapping: Mapping, width: u32, height: u32) -> Vec<f32> {
        match mapping {
            Mapping::LatLong => (0..height)
                .map(|j| mapping.texel_solid_angle(width, height, 0, j) as f32)
                .collect(),
            m => m
                .texel_solid_angles(width, height)
                .into_iter()
                .map(|w| w as f32)
                .collect(),
        }
    }

    /// The lobes of `brdf` at `queries` ((normal, towards the eye), world, unit), turned into
    /// the map's file frame by `world_to_file`, and the smallest scale among their rules; an
    /// error for the mirror, whose lobe is a lookup.
    pub fn lobes(
        brdf: Brdf,
        queries: &[(DVec3, DVec3)],
        world_to_file: DMat3,
    ) -> Result<(Vec<[f32; 4]>, f64)> {
        let mut words = Vec::with_capacity(queries.len() * QUERY_VEC4S);
        let mut scale_min = f64::INFINITY;
        for &(n, v) in queries {
            let lobe = gpu_lobe(brdf, n, v, world_to_file).ok_or_else(|| {
                Error::Invalid("the exact pass sums lobes; a mirror is a lookup".into())
            })?;
            scale_min = scale_min.min(f64::from(lobe[4][3]));
            words.extend(lobe);
        }
        Ok((words, scale_min))
    }

    /// Texels an invocation sums: where the device cuts loops short, as many as keep its
    /// iterations within 90% of the limit (one a texel, plus s² cells, s the
    /// most the rule can give a texel of angular size `rho_max` under a scale of
    /// `scale_min`, a quarter of it at the horizon; and the workgroup's tree).
    fn run_length(&self, rho_max: f64, scale_min: f64) -> u32 {
        let Some(limit) = self.ctx.info().loop_iteration_limit else {
            return RUN;
        };
        let s = (PER_WIDTH * rho_max * HORIZON_SHRINK / scale_min.max(1e-12))
            .ceil()
            .clamp(1.0, MAX_CELLS_PER_WIDTH * PER_WIDTH);
        let tree = f64::from(WORKGROUP.ilog2());
        ((0.9 * limit as f64 - tree) / (1.0 + s * s)).max(1.0) as u32
    }

    /// Partial sums a query takes (workgroups along x) for `inputs`, and the texels each
    /// invocation sums.
    pub fn layout(&self, inputs: &ExactInputs) -> (u32, u32) {
        let m = inputs.map;
        let texels = m.width * m.height * m.mapping.layers();
        let run = self.run_length(inputs.rho_max, inputs.scale_min);
        (texels.div_ceil(WORKGROUP * run), run)
    }

    /// Bytes of the partial sums [`ExactShader::record`] writes for `inputs`.
    pub fn partials_bytes(&self, inputs: &ExactInputs) -> u64 {
        u64::from(inputs.count) * u64::from(self.layout(inputs).0) * 16
    }

    /// Records the sums of `inputs` into `partials` (a storage buffer of at least
    /// [`ExactShader::partials_bytes`]): query q's partial g at vec4 q·G + g, G the first of
    /// [`ExactShader::layout`]. Span: "exact reference".
    pub fn record(
        &self,
        rec: &mut Recorder,
        inputs: &ExactInputs,
        partials: &Buffer,
    ) -> Result<()> {
        if matches!(inputs.brdf, Brdf::Mirror) {
            return Err(Error::Invalid(
                "the exact pass sums lobes; a mirror is a lookup".into(),
            ));
        }
        assert!(partials.size() >= self.partials_bytes(inputs));
        let m = inputs.map;
        let (groups, run) = self.layout(inputs);
        let [p0, p1] = inputs.brdf.params().map(|p| p as f32);
        let max = self.ctx.info().max_workgroup_count;
        rec.span("exact reference", |rec| {
            // A query a row of workgroups.
            let mut first = 0;
            while first < inputs.count {
                let batch = (inputs.count - first).min(max);
                let push = ExactShadePush {
                    size: [m.width, m.height],
                    mapping: m.mapping.id(),
                    texels: m.width * m.height * m.mapping.layers(),
                    run,
                    groups,
                    first,
                    brdf: inputs.brdf.id(),
                    p0,
                    p1,
                    per_width: PER_WIDTH as f32,
                    count: inputs.count,
                };
                rec.dispatch(
                    &self.pipeline,
                    &[
                        (
                            binding::EXACT_MAP,
                            Bind::Sampled(&m.image, &self.sampler, false),
                        ),
                        (binding::EXACT_OMEGA, Bind::Buffer(inputs.omega)),
                        (binding::EXACT_QUERIES, Bind::Buffer(inputs.lobes)),
                        (binding::EXACT_PARTIALS, Bind::Buffer(partials)),
                    ],
                    &push,
                    [groups, batch, 1],
                )?;
                first += batch;
            }
            Ok(())
        })?;
        let count = inputs.count * groups * 4;
        let rgb = Floats {
            first: 0,
            count,
            stride: 4,
            scale_mask: 0b111,
            mirror_mask: 0b111,
            sh: None,
        };
        poison::buffer(rec, PassId::Exact, partials, rgb)
    }

    /// Each query's value: the sum of its `groups` partials (vec4, rgb used), in float64.
    pub fn sum(partials: &[[f32; 4]], groups: u32) -> Vec<[f64; 3]> {
        partials
            .chunks(groups as usize)
            .map(|q| {
                let mut s = [0.0f64; 3];
                for p in q {
                    for (a, b) in s.iter_mut().zip(p) {
                        *a += f64::from(*b);
                    }
                }
                s
            })
            .collect()
    }

    /// The radiance `brdf` reflects at each of `queries` ((normal, towards the eye), world,
    /// unit) under `map`, whose file directions are `world_to_file`'s image of the world's,
    /// and waits (for the report and tests): the lobes and solid angles uploaded, the partial
    /// sums read back and added.
    pub fn run(
        &self,
        map: &GpuEnvMap,
        world_to_file: DMat3,
        brdf: Brdf,
        queries: &[(DVec3, DVec3)],
    ) -> Result<Timed<Vec<[f64; 3]>>> {
        if queries.is_empty() {
            return Ok(Timed::new(Vec::new(), Vec::new()));
        }
        let (words, scale_min) = Self::lobes(brdf, queries, world_to_file)?;
        let omega = Self::solid_angles(map.mapping, map.width, map.height);
        let rho_max = omega
            .iter()
            .fold(0.0f64, |a, &w| a.max(f64::from(w).max(0.0).sqrt()));
        let omega = Buffer::storage(&self.ctx, "exact solid angles", &omega)?;
        let lobes = Buffer::storage(&self.ctx, "exact lobes", &words)?;
        let inputs = ExactInputs {
            map,
            omega: &omega,
            rho_max,
            lobes: &lobes,
            count: queries.len() as u32,
            scale_min,
            brdf,
        };
        let (groups, _) = self.layout(&inputs);
        let out = Buffer::new(
            &self.ctx,
            "exact partials",
            self.partials_bytes(&inputs),
            vk::BufferUsageFlags::STORAGE_BUFFER,
            MemoryLocation::GpuToCpu,
        )?;
        let t = self
            .ctx
            .run("exact reference", |rec| {
                self.record(rec, &inputs, &out)?;
                rec.use_buffer(&out, Usage::HostRead);
                Ok(())
            })?
            .timings;
        let partials: Vec<[f32; 4]> = out.read(queries.len() * groups as usize);
        Ok(Timed::new(Self::sum(&partials, groups), t))
    }
}
