//! Baking one probe into what an engine loads: SH radiance coefficients, an irradiance cube
//! (from SH), a GGX-prefiltered specular cube with one MIP level per roughness, and the
//! split-sum DFG table. [`Baker`] holds every pass, so pipelines are built once per run
//! however many probes it bakes; each probe's GPU resources are freed when its bake returns,
//! so memory stays bounded.
//!
//! The specular cube's level k holds GGX α = (k/(levels − 1))² (level 0 the mirror), filtered
//! as split-sum's chain is (`crate::math::split_sum`: n = v = r, filtered importance
//! sampling from the dual-paraboloid MIP chain); an engine reads lod √α·(levels − 1).
//!
//! [`output`] says what the files hold for each engine: frames, presets, clamping, lights.

pub mod dfg_cache;
pub mod output;

use crate::error::{Error, Result};
use crate::gpu::{Buffer, Context, InFlight, Timing, Usage};
use crate::math::envmap::luminance;
use crate::math::exact::{ExactFilter, Query};
use crate::math::fis::default_dp_size;
use crate::math::lights::{
    diffuse_options, extract_block_lights, extract_lights, largest_light_rho, light_sh_of,
    record_block, resolves_rho, ExtractOptions, LightKernel, LightSet, DIFFUSE_RATIO,
};
use crate::math::sh;
use crate::math::split_sum::{level_alpha, DfgAxes};
use crate::math::Orientation;
use crate::passes::map::{LuminanceClamp, Readback};
use crate::passes::sh_project::{ShCoefficients, Subgroups};
use crate::passes::{
    ConvertOptions, Converter, GpuEnvMap, GpuLights, LightsPass, MipChain, PrefilterOptions,
    ShEvaluator, ShProjector, SplitSum,
};
use crate::{EnvMap, Mapping};
use ash::vk;
use gpu_allocator::MemoryLocation;

/// What a bake computes: [`BakeOptions::new`] or [`Default`] (what `envlight bake` writes
/// without flags), then the fields that differ.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields, default)]
#[non_exhaustive]
pub struct BakeOptions {
    /// Highest SH band of the coefficients written (the irradiance cube uses them all).
    pub sh_order: u32,
    /// Face size of the irradiance cube.
    pub irradiance_size: u32,
    /// Face size of the specular cube's level 0.
    pub specular_size: u32,
    /// Roughness levels of the specular cube.
    pub specular_levels: u32,
    /// FIS samples per specular texel.
    pub samples: u32,
    /// Lod bias of those samples.
    pub bias: f64,
    /// Entries per side of the DFG table.
    pub dfg_size: u32,
    /// Also return the dual-paraboloid MIP chain the specular cube is filtered from (what
    /// filtered importance sampling reads at run time).
    pub chain: bool,
    /// Extract the map's lights (`crate::math::lights`) and add them exactly to the
    /// irradiance cube and the specular levels ≥ 1, which then see only the residual
    /// through SH and FIS.
    pub lights: bool,
    /// The finest light records of the specular levels, as a lat-long map's width (a cube's
    /// faces: a quarter of it): on a larger map each record gathers a block of texels
    /// (`crate::math::lights::record_block`), so that the same light bakes the same, at the
    /// same cost, at any resolution.
    pub light_record_width: u32,
}

impl BakeOptions {
    /// A specular cube of `specular_size`² at level 0, the rest as [`Default`] has it.
    pub fn new(specular_size: u32) -> Self {
        BakeOptions {
            specular_size,
            ..Default::default()
        }
    }
}

impl Default for BakeOptions {
    fn default() -> Self {
        BakeOptions {
            sh_order: 2,
            irradiance_size: 32,
            specular_size: 256,
            specular_levels: 8,
            samples: crate::abi::split_sum::DEFAULT_SAMPLES,
            bias: crate::math::fis::DEFAULT_BIAS,
            dfg_size: crate::abi::split_sum::DEFAULT_DFG_SIZE,
            chain: false,
            lights: true,
            light_record_width: crate::abi::lights::RECORD_WIDTH,
        }
    }
}

impl BakeOptions {
    /// Checks every value; the message names the option.
    pub fn validate(&self) -> Result<()> {
        let bad = |m: String| Err(Error::Invalid(m));
        if self.sh_order > crate::abi::SH_MAX_LMAX {
            return bad(format!("sh_order {} is above 8", self.sh_order));
        }
        if !(1..=4096).contains(&self.irradiance_size) {
            return bad(format!(
                "irradiance_size {} outside 1 to 4096",
                self.irradiance_size
            ));
        }
        if !(1..=4096).contains(&self.specular_size) {
            return bad(format!(
                "specular_size {} outside 1 to 4096",
                self.specular_size
            ));
        }
        let most = crate::passes::map::full_mips(self.specular_size, self.specular_size);
        if !(1..=most).contains(&self.specular_levels) {
            return bad(format!(
                "specular_levels {} outside 1 to {most} for a {}² cube",
                self.specular_levels, self.specular_size
            ));
        }
        if !(1..=crate::scene::MAX_FIS_SAMPLES).contains(&self.samples) {
            return bad(format!("samples {} outside 1 to 16384", self.samples));
        }
        if !(self.bias.is_finite() && self.bias.abs() <= 16.0) {
            return bad("bias must be within ±16".into());
        }
        if !(4..=1 << 20).contains(&self.light_record_width) {
            return bad(format!(
                "light_record_width {} outside 4 to 1048576",
                self.light_record_width
            ));
        }
        if !(2..=crate::abi::split_sum::MAX_DFG_SIZE).contains(&self.dfg_size) {
            return bad(format!("dfg_size {} outside 2 to 256", self.dfg_size));
        }
        Ok(())
    }
}

/// One probe's bake, on the host.
pub struct Baked {
    /// Radiance SH coefficients to `sh_order`.
    pub sh: ShCoefficients,
    /// The irradiance cube, faces × rows × columns, RGBA (A = 1).
    pub irradiance: Vec<[f32; 4]>,
    /// The specular cube's levels, level 0 first, each faces × rows × columns, RGBA (A = 1).
    pub specular: Vec<Vec<[f32; 4]>>,
    /// With [`BakeOptions::chain`]: the dual-paraboloid MIP chain, level 0 ([`dp_size`] a
    /// side) first, each two halves (+Y, −Y) × rows × columns, RGBA as stored; else empty.
    pub chain: Vec<Vec<[f32; 4]>>,
    /// GPU time per pass.
    pub timings: Vec<Timing>,
}

/// How a bake's cubes compare with exact filters of its source at a few texels
/// ([`spot_check`]): the worst relative error (luminance) among them.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct SpotCheck {
    /// Texels checked per cube level.
    pub texels: u32,
    /// The irradiance cube (SH to `sh_order`) against ∫ L·max(0, n·ω) dω.
    pub irradiance: f64,
    /// The specular cube per level against `ExactFilter::ggx`; level 0 (the mirror, a
    /// resampling) is not checked and holds 0.
    pub specular: Vec<f64>,
}

impl SpotCheck {
    /// The worst over the specular levels (NaN where any is).
    pub fn specular_worst(&self) -> f64 {
        self.specular.iter().copied().fold(0.0, worse)
    }
}

/// The larger of two errors, NaN where either is (`f64::max` would drop it and call a check
/// that computed NaN clean).
fn worse(a: f64, b: f64) -> f64 {
    if a.is_nan() || b.is_nan() {
        f64::NAN
    } else {
        a.max(b)
    }
}

/// The cube texel (layer, i, j) of a `size`-side face holding world direction `d`.
fn cube_texel(size: u32, d: glam::DVec3) -> (u32, u32, u32) {
    let c = Mapping::Cube.dir_to_coord(d);
    let at = |x: f64| ((x * size as f64).floor().max(0.0) as u32).min(size - 1);
    (c.layer, at(c.u), at(c.v))
}

/// Checks `baked` (of `env` seen with `orientation`) against float64 exact filters at
/// `texels` texels of the irradiance cube and of each specular level ≥ 1: first the texel
/// holding the source's brightest texel (a sun, where filtering errs most), then texels spread
/// over the faces by a fixed rule, so that the same bake checks the same texels.
pub fn spot_check(
    env: &EnvMap,
    orientation: &Orientation,
    opts: &BakeOptions,
    baked: &Baked,
    texels: u32,
) -> SpotCheck {
    let exact = ExactFilter::new(env, orientation.world_to_file().transpose());
    let sun = exact.brightest();
    let pick = |size: u32, q: u32| -> (u32, u32, u32) {
        if q == 0 {
            cube_texel(size, sun)
        } else {
            (q % 6, (q * 37 + 11) % size, (q * 23 + 5) % size)
        }
    };
    let centre = |size: u32, (layer, i, j): (u32, u32, u32)| {
        Mapping::Cube.coord_to_dir(Mapping::texel_center(size, size, layer, i, j))
    };
    let rel = |got: [f32; 4], want: [f64; 3]| {
        let g = luminance([got[0] as f64, got[1] as f64, got[2] as f64]);
        let w = luminance(want);
        if w > 0.0 {
            (g - w).abs() / w
        } else {
            g.abs()
        }
    };
    // (level, or None for the irradiance cube; texel centre; baked value).
    let mut jobs: Vec<(Option<u32>, glam::DVec3, [f32; 4])> = Vec::new();
    let s = opts.irradiance_size;
    for q in 0..texels {
        let t = pick(s, q);
        let got = baked.irradiance[((t.0 * s + t.2) * s + t.1) as usize];
        jobs.push((None, centre(s, t), got));
    }
    for k in 1..opts.specular_levels {
        let s = (opts.specular_size >> k).max(1);
        for q in 0..texels {
            let t = pick(s, q);
            let got = baked.specular[k as usize][((t.0 * s + t.2) * s + t.1) as usize];
            jobs.push((Some(k), centre(s, t), got));
        }
    }
    // The exact filters, every query in one pass over the map on every core: they cost as
    // much as the bake's GPU work on a CPU device.
    let queries: Vec<Query> = jobs
        .iter()
        .map(|&(level, d, _)| match level {
            None => Query::Irradiance { n: d },
            Some(k) => Query::Ggx {
                r: d,
                alpha: level_alpha(k, opts.specular_levels),
            },
        })
        .collect();
    let errors: Vec<f64> = exact
        .evaluate(&queries)
        .into_iter()
        .zip(&jobs)
        .map(|(want, &(_, _, got))| rel(got, want))
        .collect();
    let mut irradiance: f64 = 0.0;
    let mut specular = vec![0.0f64; opts.specular_levels as usize];
    for (&(level, _, _), e) in jobs.iter().zip(errors) {
        match level {
            None => irradiance = worse(irradiance, e),
            Some(k) => specular[k as usize] = worse(specular[k as usize], e),
        }
    }
    SpotCheck {
        texels,
        irradiance,
        specular,
    }
}

/// What a bake's submission reads back.
struct Downloads {
    sh: Buffer,
    irradiance: Readback,
    specular: Vec<Readback>,
    chain: Vec<Readback>,
}

/// A bake [`Baker::submit`] handed to the GPU; [`PendingBake::wait`] finishes it (dropping
/// it waits too, and discards the results).
pub struct PendingBake {
    inflight: InFlight<Downloads>,
    lmax: u32,
}

impl PendingBake {
    /// Waits for the GPU and reads the results back; refuses a non-finite texel.
    pub fn wait(self) -> Result<Baked> {
        let (d, timings) = self.inflight.wait()?;
        let flat: Vec<f32> = d.sh.read(sh::count(self.lmax) * 3);
        let sh = ShCoefficients::from_f32(self.lmax, &flat);
        let irradiance = d.irradiance.read();
        let specular: Vec<Vec<[f32; 4]>> = d.specular.iter().map(|r| r.read()).collect();
        let chain: Vec<Vec<[f32; 4]>> = d.chain.iter().map(|r| r.read()).collect();
        let finite = |v: &[[f32; 4]]| v.iter().all(|t| t.iter().all(|c| c.is_finite()));
        let sh_finite = flat.iter().all(|c| c.is_finite());
        if !sh_finite || !finite(&irradiance) || !specular.iter().chain(&chain).all(|l| finite(l)) {
            return Err(Error::Invalid(
                "bake: a non-finite texel left the GPU".into(),
            ));
        }
        Ok(Baked {
            sh,
            irradiance: irradiance
                .into_iter()
                .map(|t| [t[0], t[1], t[2], 1.0])
                .collect(),
            specular: specular
                .into_iter()
                .map(|l| l.into_iter().map(|t| [t[0], t[1], t[2], 1.0]).collect())
                .collect(),
            chain,
            timings,
        })
    }
}

/// Side of the dual paraboloid the specular cube is filtered from: the source's own
/// resolution (`default_dp_size`), but no finer than twice the cube's face, which already
/// samples the mirror level as finely as the cube holds it (a paraboloid half spans the
/// hemisphere a cube spans with about two faces' widths of texels at its equator).
pub fn dp_size(env: &EnvMap, opts: &BakeOptions) -> u32 {
    default_dp_size(env).min((2 * opts.specular_size).next_power_of_two().max(16))
}

/// Samples per axis per texel of the paraboloid's conversion: 1.5 per source texel spacing,
/// at least 2 — a third of the general rule's 4 ([`Converter::supersampling`]). The
/// paraboloid only feeds FIS's MIP chain and the mirror level; measured on four 1k probes,
/// no spot-checked error moved in its first three digits, and the conversion costs a sixth.
pub fn supersample(env: &EnvMap, dp_size: u32) -> u32 {
    let (w, h) = Mapping::DualParaboloid.extent_for_size(dp_size);
    let r = Converter::ratio(
        (env.mapping, env.width, env.height),
        (Mapping::DualParaboloid, w, h),
    );
    ((1.5 * r).ceil() as u32).clamp(2, 64)
}

/// A bake's light extractions of `env`: the specular levels' (records in blocks of texels on
/// maps finer than `light_record_width`, `record_block`, so that a map bakes as the same
/// content at that size does; none where its texels are too coarse for level 1's lobe,
/// `finest`), the grid their records index (`None`: `env`'s texels), and the irradiance
/// cube's (a deeper extraction whose texels' SH the cube takes out of the whole map's and
/// adds back as clusters, as SH objects render). Each `None` where nothing was extracted.
fn bake_extractions(
    env: &EnvMap,
    opts: &BakeOptions,
    finest: f64,
) -> (Option<LightSet>, Option<EnvMap>, Option<LightSet>) {
    // Neither residual map is built: the cubes need the specular one's only on the GPU,
    // where the source is clamped in place (`LuminanceClamp`), and the diffuse one's not at
    // all (its SH is the whole map's less the lights').
    let diffuse = extract_lights(env, &diffuse_options(DIFFUSE_RATIO));
    let block = record_block(env, opts.light_record_width);
    let (grid, specular) = extract_block_lights(env, &ExtractOptions::default(), block);
    let specular = Some(specular)
        .filter(|e| !e.lights.is_empty() && resolves_rho(largest_light_rho(&e.lights), finest));
    let diffuse = Some(diffuse).filter(|e| !e.lights.is_empty());
    (specular, grid, diffuse)
}

/// The passes of a bake, built once.
pub struct Baker {
    ctx: Context,
    sh: ShProjector,
    eval: ShEvaluator,
    convert: Converter,
    mip: MipChain,
    split: SplitSum,
    lights: LightsPass,
    clamp: LuminanceClamp,
}

impl Baker {
    /// Builds every pass.
    pub fn new(ctx: &Context) -> Result<Baker> {
        Ok(Baker {
            ctx: ctx.clone(),
            sh: ShProjector::new(ctx, Subgroups::Auto)?,
            eval: ShEvaluator::new(ctx)?,
            convert: Converter::new(ctx)?,
            mip: MipChain::new(ctx)?,
            split: SplitSum::new(ctx)?,
            lights: LightsPass::new(ctx)?,
            clamp: LuminanceClamp::new(ctx)?,
        })
    }

    /// Bakes `env` seen with `orientation` and waits ([`Baker::submit`], then
    /// [`PendingBake::wait`]).
    pub fn bake(
        &self,
        env: &EnvMap,
        orientation: &Orientation,
        opts: &BakeOptions,
    ) -> Result<Baked> {
        self.submit(env, orientation, opts)?.wait()
    }

    /// Records the whole bake of `env` — its upload, the SH projection, the irradiance cube
    /// from the projected coefficients (copied on the GPU, no readback between), the
    /// paraboloid and its MIP chain, the specular cube, and every download — into one
    /// submission, and returns without waiting. Submitting the next probe before waiting for
    /// this one overlaps that probe's upload and recording (and the caller's work on this
    /// probe's results) with this probe's GPU work; on a device with one queue the GPU itself
    /// runs the submissions one after the other, without idling between them.
    pub fn submit(
        &self,
        env: &EnvMap,
        orientation: &Orientation,
        opts: &BakeOptions,
    ) -> Result<PendingBake> {
        opts.validate()?;
        let ctx = &self.ctx;
        let lmax = opts.sh_order;
        let src = GpuEnvMap::new(ctx, "bake: source", env.mapping, env.width, env.height)?;
        let sh_out = Buffer::new(
            ctx,
            "bake: SH coefficients",
            ShProjector::output_bytes(lmax),
            vk::BufferUsageFlags::TRANSFER_DST | vk::BufferUsageFlags::TRANSFER_SRC,
            MemoryLocation::GpuToCpu,
        )?;
        let irradiance_map = GpuEnvMap::new(
            ctx,
            "bake: irradiance cube",
            Mapping::Cube,
            opts.irradiance_size,
            opts.irradiance_size,
        )?;
        let dp_size = dp_size(env, opts);
        let (w, h) = Mapping::DualParaboloid.extent_for_size(dp_size);
        let dp = GpuEnvMap::with_mips(ctx, "bake: paraboloid", Mapping::DualParaboloid, w, h)?;
        let cube = SplitSum::cube_chain(ctx, opts.specular_size, opts.specular_levels)?;
        // With lights: the residual's own upload and paraboloid, and the light texels, for the
        // specular levels. The finest lobe the light texels' quadrature must resolve: level
        // 1's (a source too coarse for it bakes its specular levels without lights, as
        // `resolves` says).
        let finest = level_alpha(1, opts.specular_levels.max(2));
        let (extraction, grid, diffuse) = match opts.lights {
            true => bake_extractions(env, opts, finest),
            false => (None, None, None),
        };
        let file_to_world = orientation.checked_world_to_file()?.transpose();
        let lights = GpuLights::of_lights(
            ctx,
            grid.as_ref().unwrap_or(env),
            extraction.as_ref().map(|e| e.lights.as_slice()),
            diffuse.as_ref().map(|e| e.lights.as_slice()),
            file_to_world,
            finest,
        )?;
        let minus = diffuse
            .as_ref()
            .map(|ex| sh::irradiance_coeffs(&light_sh_of(env, &ex.lights, file_to_world, lmax)));
        // The residual's paraboloid, from the source clamped in place at the threshold once
        // the passes reading the whole map have read it.
        let residual = match &extraction {
            Some(ex) => {
                let dp = GpuEnvMap::with_mips(
                    ctx,
                    "bake: residual paraboloid",
                    Mapping::DualParaboloid,
                    w,
                    h,
                )?;
                Some((ex.threshold, dp))
            }
            None => None,
        };
        let orientation = *orientation;
        let opts = *opts;
        let inflight = ctx.submit("baking a probe", move |rec| {
            src.record_upload(rec, env)?;
            self.sh
                .record_into(rec, &src, lmax, &orientation, &sh_out)?;
            let c = ConvertOptions::new(Mapping::DualParaboloid, dp_size)
                .with_orientation(orientation)
                .with_supersample(Some(supersample(env, dp_size)));
            self.convert.record(rec, &src, &dp, &c)?;
            self.mip.record(rec, &dp)?;
            let p = PrefilterOptions {
                levels: opts.specular_levels,
                samples: opts.samples,
                bias: opts.bias,
            };
            match (&minus, &lights) {
                (Some(minus), Some(lights)) => {
                    self.eval.record_irradiance_minus(
                        rec,
                        &sh_out,
                        lmax,
                        minus,
                        &irradiance_map,
                    )?;
                    self.lights
                        .record_clusters(rec, lights, &irradiance_map, 0)?;
                }
                _ => {
                    self.eval
                        .record_irradiance(rec, &sh_out, lmax, &irradiance_map)?;
                }
            }
            match (&residual, &lights) {
                (Some((threshold, rdp)), Some(lights)) => {
                    // The mirror from the whole map; the rest from the residual plus lights.
                    self.clamp.record(rec, &src, *threshold)?;
                    self.convert.record(rec, &src, rdp, &c)?;
                    self.mip.record(rec, rdp)?;
                    self.split
                        .record_prefilter_levels(rec, &dp, &cube, &p, 0..1)?;
                    self.split.record_prefilter_levels(
                        rec,
                        rdp,
                        &cube,
                        &p,
                        1..opts.specular_levels,
                    )?;
                    for k in 1..opts.specular_levels {
                        let alpha = level_alpha(k, opts.specular_levels);
                        self.lights
                            .record(rec, lights, LightKernel::Ggx { alpha }, &cube, k)?;
                    }
                }
                _ => self.split.record_prefilter(rec, &dp, &cube, &p)?,
            }
            rec.use_buffer(&sh_out, Usage::HostRead);
            let irradiance = irradiance_map.record_download(rec, 0)?;
            let specular = (0..opts.specular_levels)
                .map(|k| cube.record_download(rec, k))
                .collect::<Result<Vec<_>>>()?;
            let chain = if opts.chain {
                (0..dp.mips())
                    .map(|k| dp.record_download(rec, k))
                    .collect::<Result<Vec<_>>>()?
            } else {
                Vec::new()
            };
            rec.keep((src, irradiance_map, dp, cube));
            if let Some((_, rdp)) = residual {
                rec.keep(rdp);
            }
            if let Some(lights) = lights {
                rec.keep(lights);
            }
            Ok(Downloads {
                sh: sh_out,
                irradiance,
                specular,
                chain,
            })
        })?;
        Ok(PendingBake { inflight, lmax })
    }

    /// The split-sum DFG table (height-correlated Smith unless `correlated` is false), row
    /// √α = j/(size − 1) after row, (A, B) per entry.
    pub fn dfg(&self, size: u32, correlated: bool) -> Result<Vec<[f32; 2]>> {
        self.dfg_at(size, correlated, DfgAxes::Endpoints)
    }

    /// [`Baker::dfg`] with its entries where `axes` puts them.
    pub fn dfg_at(&self, size: u32, correlated: bool, axes: DfgAxes) -> Result<Vec<[f32; 2]>> {
        Ok(self.split.run_dfg_at(size, correlated, axes)?.0)
    }
}
