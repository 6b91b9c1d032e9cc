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
pub mod files;
pub mod gallery;
pub mod manifest;
pub mod output;
pub mod plan;
pub mod preview;
mod run;
pub mod schedule;
pub mod set;

use crate::error::{Error, Result};
use crate::gpu::{Buffer, Context, InFlight, Recorder, Timed, Timing, Usage};
use crate::math::envmap::luminance;
use crate::math::exact::{ExactFilter, Query};
use crate::math::fis::default_dp_size;
use crate::math::lights::{
    block_means, diffuse_options, extract_block_lights, extract_lights, largest_light_rho,
    light_sh_of, record_block, resolves_rho, ExtractOptions, LightKernel, LightSet, DIFFUSE_RATIO,
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
pub(crate) fn worse(a: f64, b: f64) -> f64 {
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
/// over the faces by a fixed rule, so that the same bake checks the same texels
/// ([`SpotCheckPlan::new`], then [`SpotCheckPlan::compare`]).
pub fn spot_check(
    env: &EnvMap,
    orientation: &Orientation,
    opts: &BakeOptions,
    baked: &Baked,
    texels: u32,
) -> SpotCheck {
    SpotCheckPlan::new(env, orientation, opts, texels).compare(baked)
}

/// A spot check's exact values, which depend on the source alone: a caller computes them
/// while the GPU bakes (on a CPU device they cost as much as the bake's GPU work), then
/// compares the bake with them.
#[derive(Clone, Debug)]
pub struct SpotCheckPlan {
    texels: u32,
    levels: u32,
    jobs: Vec<CheckedTexel>,
}

/// One texel a spot check compares.
#[derive(Clone, Copy, Debug)]
struct CheckedTexel {
    /// The specular level, or None for the irradiance cube.
    level: Option<u32>,
    /// Its face side.
    side: u32,
    /// (layer, i, j).
    texel: (u32, u32, u32),
    /// The exact filter there.
    want: [f64; 3],
}

impl SpotCheckPlan {
    /// The texels [`spot_check`] checks in a bake of `env` with `opts`, and the exact filters
    /// of `env` there: every query in one pass over the map on every core.
    pub fn new(
        env: &EnvMap,
        orientation: &Orientation,
        opts: &BakeOptions,
        texels: u32,
    ) -> SpotCheckPlan {
        let exact = ExactFilter::new(env, orientation.world_to_file().transpose());
        let sun = exact.brightest();
        let pick = |size: u32, q: u32| -> (u32, u32, u32) {
            if q == 0 {
                cube_texel(size, sun)
            } else {
                (q % 6, (q * 37 + 11) % size, (q * 23 + 5) % size)
            }
        };
        let mut jobs = Vec::new();
        for q in 0..texels {
            jobs.push((None, opts.irradiance_size, pick(opts.irradiance_size, q)));
        }
        for k in 1..opts.specular_levels {
            let s = (opts.specular_size >> k).max(1);
            jobs.extend((0..texels).map(|q| (Some(k), s, pick(s, q))));
        }
        let queries: Vec<Query> = jobs
            .iter()
            .map(|&(level, s, (layer, i, j))| {
                let d = Mapping::Cube.coord_to_dir(Mapping::texel_center(s, s, layer, i, j));
                match level {
                    None => Query::Irradiance { n: d },
                    Some(k) => Query::Ggx {
                        r: d,
                        alpha: level_alpha(k, opts.specular_levels),
                    },
                }
            })
            .collect();
        let want = exact.evaluate(&queries);
        SpotCheckPlan {
            texels,
            levels: opts.specular_levels,
            jobs: jobs
                .into_iter()
                .zip(want)
                .map(|((level, side, texel), want)| CheckedTexel {
                    level,
                    side,
                    texel,
                    want,
                })
                .collect(),
        }
    }

    /// The worst relative luminance error of `baked` (a bake with the options this plan was
    /// made for) at the plan's texels, per cube level.
    pub fn compare(&self, baked: &Baked) -> SpotCheck {
        let rel = |got: [f32; 4], want: [f64; 3]| {
            let g = luminance([got[0] as f64, got[1] as f64, got[2] as f64]);
            let w = luminance(want);
            if w > 0.0 {
                (g - w).abs() / w
            } else {
                g.abs()
            }
        };
        let mut irradiance: f64 = 0.0;
        let mut specular = vec![0.0f64; self.levels as usize];
        for &CheckedTexel {
            level,
            side: s,
            texel: (layer, i, j),
            want,
        } in &self.jobs
        {
            let at = ((layer * s + j) * s + i) as usize;
            match level {
                None => irradiance = worse(irradiance, rel(baked.irradiance[at], want)),
                Some(k) => {
                    let e = rel(baked.specular[k as usize][at], want);
                    specular[k as usize] = worse(specular[k as usize], e);
                }
            }
        }
        SpotCheck {
            texels: self.texels,
            irradiance,
            specular,
        }
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
    host: HostSeconds,
}

/// Where [`Baker::submit`] spent its own (host) time.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct HostSeconds {
    /// Statistics and light extraction, and the grids of block means.
    pub lights: f64,
    /// Writing the source into staging memory (and, for a large map, its banded upload,
    /// which waits for the GPU) and recording the submission, with whatever of the
    /// pipelines' compilation ([`Baker::prepare`]) outlasted the light extraction.
    pub upload: f64,
}

impl PendingBake {
    /// Where the submission spent its host time.
    pub fn host_seconds(&self) -> HostSeconds {
        self.host
    }

    /// Waits for the GPU and reads the results back; refuses a non-finite texel.
    pub fn wait(self) -> Result<Baked> {
        let Timed { value: d, timings } = self.inflight.wait()?;
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

/// Samples per axis per texel of the paraboloid's conversion: the chain's rate
/// ([`Converter::chain_supersampling`]), the paraboloid feeding only FIS's MIP chain and the
/// mirror level.
pub fn supersample(env: &EnvMap, dp_size: u32) -> u32 {
    Converter::chain_supersampling((env.mapping, env.width, env.height), dp_size)
}

/// The most staging a bake's upload of its source takes (64 MiB, 4 Mi texels: a 2896 × 1448
/// lat-long); a larger map is uploaded in bands of rows ([`GpuEnvMap::upload_banded`]) so
/// that the host holds no second copy of it (16 bytes a texel on top of its own 12).
const UPLOAD_BAND_BYTES: u64 = 64 << 20;

/// The host side of a bake before its recording: its light extractions, and the grids of
/// block means that a map finer than the light records' grid converts from.
struct Prepared {
    /// The specular levels' records (in blocks of texels on maps finer than
    /// `light_record_width`, `record_block`, so that a map bakes as the same content at that
    /// size does); `None` without lights, or where its texels are too coarse for level 1's
    /// lobe (`finest`).
    specular: Option<LightSet>,
    /// The grid of block means the records index (`None`: `env`'s own texels).
    records_grid: Option<EnvMap>,
    /// The grid of block means the paraboloids are converted from (`None`: `env` itself).
    grid: Option<EnvMap>,
    /// The residual's block means, beside `grid` where there are specular records.
    residual_grid: Option<EnvMap>,
    /// The irradiance cube's lights: a deeper extraction whose texels' SH the cube takes out
    /// of the whole map's and adds back as clusters, as SH objects render.
    diffuse: Option<LightSet>,
}

/// [`Prepared`] for `env`. No residual map is built at `env`'s resolution: the specular
/// levels convert the residual's block means where there is a grid, else the source clamped
/// texel by texel on the GPU as it is converted (`Converter::record_split`; a cube source is
/// clamped in place first, `LuminanceClamp`); the irradiance needs none (its SH is the whole
/// map's less the lights'). The paraboloids' grid is at least as fine as the records' and 4
/// × the cube's face wide (lat-long; a face as wide as the cube's on a cube), finer than
/// the mirror level holds the sphere: the records' own where that is as fine, else its own.
fn prepare(env: &EnvMap, opts: &BakeOptions, finest: f64) -> Prepared {
    let block = record_block(env, opts.light_record_width);
    let converted = record_block(env, (4 * opts.specular_size).max(opts.light_record_width));
    let means = |threshold: f64| {
        let (grid, residual_grid) = block_means(env, converted, threshold).unzip();
        (grid, residual_grid.flatten())
    };
    if !opts.lights {
        let (grid, _) = means(f64::INFINITY);
        return Prepared {
            specular: None,
            records_grid: None,
            grid,
            residual_grid: None,
            diffuse: None,
        };
    }
    let diffuse = extract_lights(env, &diffuse_options(DIFFUSE_RATIO));
    let b = extract_block_lights(env, &ExtractOptions::default(), block);
    let specular = Some(b.set)
        .filter(|e| !e.lights.is_empty() && resolves_rho(largest_light_rho(&e.lights), finest));
    let (grid, residual_grid) = match converted == block {
        true => (b.grid.clone(), b.residual_grid),
        false => means(specular.as_ref().map_or(f64::INFINITY, |s| s.threshold)),
    };
    Prepared {
        residual_grid: residual_grid.filter(|_| specular.is_some()),
        specular,
        records_grid: b.grid,
        grid,
        diffuse: Some(diffuse).filter(|e| !e.lights.is_empty()),
    }
}

/// Where the residual's paraboloid is converted from.
enum ResidualFrom {
    /// The source clamped at this luminance: as one conversion writes both paraboloids
    /// (2D sources), or in place once the passes reading the whole map have read it (cubes).
    Clamp(f64),
    /// The residual's block means ([`Prepared::residual_grid`]), uploaded into this image.
    Grid(Box<GpuEnvMap>),
}

/// A bake's images besides its source.
struct Images {
    irradiance: GpuEnvMap,
    /// The whole map's paraboloid (its MIP chain FIS reads).
    dp: GpuEnvMap,
    cube: GpuEnvMap,
    /// The grid of block means the paraboloids convert from, where there is one.
    reduced: Option<GpuEnvMap>,
    /// The residual's source and paraboloid, where the specular levels take lights.
    residual: Option<(ResidualFrom, GpuEnvMap)>,
}

impl Images {
    fn new(ctx: &Context, env: &EnvMap, opts: &BakeOptions, prep: &Prepared) -> Result<Images> {
        let size = opts.irradiance_size;
        let irradiance = GpuEnvMap::new(ctx, "bake: irradiance cube", Mapping::Cube, size, size)?;
        let (w, h) = Mapping::DualParaboloid.extent_for_size(dp_size(env, opts));
        let paraboloid = |name| GpuEnvMap::with_mips(ctx, name, Mapping::DualParaboloid, w, h);
        let dp = paraboloid("bake: paraboloid")?;
        let cube = SplitSum::cube_chain(ctx, opts.specular_size, opts.specular_levels)?;
        let image = |name, m: &EnvMap| GpuEnvMap::new(ctx, name, m.mapping, m.width, m.height);
        let reduced = match &prep.grid {
            Some(g) => Some(image("bake: block means", g)?),
            None => None,
        };
        let residual = match (&prep.specular, &prep.residual_grid) {
            (Some(_), Some(g)) => Some(ResidualFrom::Grid(Box::new(image(
                "bake: residual block means",
                g,
            )?))),
            (Some(set), None) => Some(ResidualFrom::Clamp(set.threshold)),
            (None, _) => None,
        };
        let residual = match residual {
            Some(from) => Some((from, paraboloid("bake: residual paraboloid")?)),
            None => None,
        };
        Ok(Images {
            irradiance,
            dp,
            cube,
            reduced,
            residual,
        })
    }
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
    /// Builds every pass, on two threads (a pipeline costs llvmpipe milliseconds of
    /// compilation; the pipelines that depend on a probe's mapping and options are built by
    /// [`Baker::prepare`]).
    pub fn new(ctx: &Context) -> Result<Baker> {
        std::thread::scope(|s| {
            let other = s.spawn(|| -> Result<_> {
                Ok((
                    ShProjector::new(ctx, Subgroups::Auto)?,
                    ShEvaluator::new(ctx)?,
                    LightsPass::new(ctx)?,
                    LuminanceClamp::new(ctx)?,
                ))
            });
            let (convert, mip, split) = (
                Converter::new(ctx)?,
                MipChain::new(ctx)?,
                SplitSum::new(ctx)?,
            );
            let (sh, eval, lights, clamp) = join(other)?;
            Ok(Baker {
                ctx: ctx.clone(),
                sh,
                eval,
                convert,
                mip,
                split,
                lights,
                clamp,
            })
        })
    }

    /// Builds the pipelines that a bake of a `mapping` map with `opts` records and that
    /// [`Baker::new`] leaves (the SH projection's for the map's mapping and order, the
    /// paraboloids' conversion), on two threads, now rather than as it records.
    /// [`Baker::submit`] calls it beside its host work; they are built once.
    pub fn prepare(&self, mapping: Mapping, opts: &BakeOptions) -> Result<()> {
        std::thread::scope(|s| {
            let sh = s.spawn(|| self.sh.prepare(opts.sh_order, mapping));
            match mapping {
                Mapping::Cube => self.convert.prepare(mapping, Mapping::DualParaboloid)?,
                _ => self.convert.prepare_split(mapping)?,
            }
            join(sh)
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
    ///
    /// A map finer than the light records' grid (`BakeOptions::light_record_width`) is
    /// projected onto SH at its own resolution, and its paraboloids are converted from its
    /// block means (and the residual's), which hold the same power in every block: the same
    /// content at any size converts the same, at the grid's cost.
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
        // The finest lobe the light texels' quadrature must resolve: level 1's (a source too
        // coarse for it bakes its specular levels without lights, as `resolves` says).
        let finest = level_alpha(1, opts.specular_levels.max(2));
        let t0 = std::time::Instant::now();
        // The host's light extraction beside the pipelines' compilation.
        let (prep, lights_s) = std::thread::scope(|s| {
            let pipelines = s.spawn(|| self.prepare(env.mapping, opts));
            let prep = prepare(env, opts, finest);
            let lights_s = t0.elapsed().as_secs_f64();
            join(pipelines).map(|()| (prep, lights_s))
        })?;
        let images = Images::new(ctx, env, opts, &prep)?;
        let file_to_world = orientation.checked_world_to_file()?.transpose();
        let lights = GpuLights::of_lights(
            ctx,
            prep.records_grid.as_ref().unwrap_or(env),
            prep.specular.as_ref().map(|e| e.lights.as_slice()),
            prep.diffuse.as_ref().map(|e| e.lights.as_slice()),
            file_to_world,
            finest,
        )?;
        let minus = prep
            .diffuse
            .as_ref()
            .map(|ex| sh::irradiance_coeffs(&light_sh_of(env, &ex.lights, file_to_world, lmax)));
        // A large map goes up in bands through bounded staging before the bake's submission
        // (which then waits for the work queued before it); a small one with the bake.
        let banded = env.texels.len() as u64 * 16 > UPLOAD_BAND_BYTES;
        if banded {
            src.upload_banded(ctx, env, UPLOAD_BAND_BYTES)?;
        }
        let orientation = *orientation;
        let opts = *opts;
        let inflight = ctx.submit("baking a probe", move |rec| {
            if !banded {
                src.record_upload(rec, env)?;
            }
            self.sh
                .record_into(rec, &src, lmax, &orientation, &sh_out)?;
            let i = &images;
            match (&minus, &lights) {
                (Some(minus), Some(lights)) => {
                    self.eval
                        .record_irradiance_minus(rec, &sh_out, lmax, minus, &i.irradiance)?;
                    self.lights.record_clusters(rec, lights, &i.irradiance, 0)?;
                }
                _ => self
                    .eval
                    .record_irradiance(rec, &sh_out, lmax, &i.irradiance)?,
            }
            self.record_specular(
                rec,
                env,
                &src,
                &prep,
                i,
                lights.as_ref(),
                &orientation,
                &opts,
            )?;
            rec.use_buffer(&sh_out, Usage::HostRead);
            let irradiance = i.irradiance.record_download(rec, 0)?;
            let specular = (0..opts.specular_levels)
                .map(|k| i.cube.record_download(rec, k))
                .collect::<Result<Vec<_>>>()?;
            let chain = match opts.chain {
                true => (0..i.dp.mips())
                    .map(|k| i.dp.record_download(rec, k))
                    .collect::<Result<Vec<_>>>()?,
                false => Vec::new(),
            };
            rec.keep((src, images));
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
        let host = HostSeconds {
            lights: lights_s,
            upload: t0.elapsed().as_secs_f64() - lights_s,
        };
        Ok(PendingBake {
            inflight,
            lmax,
            host,
        })
    }

    /// Records the specular cube: the whole map's paraboloid (from `src`, or from the grid of
    /// block means) and its chain, level 0 (the mirror) from it; with lights, levels 1 and up
    /// from the residual's paraboloid plus the light records.
    #[allow(clippy::too_many_arguments)]
    fn record_specular(
        &self,
        rec: &mut Recorder,
        env: &EnvMap,
        src: &GpuEnvMap,
        prep: &Prepared,
        i: &Images,
        lights: Option<&GpuLights>,
        orientation: &Orientation,
        opts: &BakeOptions,
    ) -> Result<()> {
        let dp_size = dp_size(env, opts);
        let (from, from_map) = match (&i.reduced, &prep.grid) {
            (Some(r), Some(g)) => {
                r.record_upload(rec, g)?;
                (r, g)
            }
            _ => (src, env),
        };
        let c = ConvertOptions::new(Mapping::DualParaboloid, dp_size)
            .with_orientation(*orientation)
            .with_supersample(Some(supersample(from_map, dp_size)));
        let p = PrefilterOptions {
            samples: opts.samples,
            bias: opts.bias,
            ..PrefilterOptions::new(opts.specular_levels)
        };
        let (Some((residual, rdp)), Some(lights)) = (&i.residual, lights) else {
            self.convert.record(rec, from, &i.dp, &c)?;
            self.mip.record(rec, &i.dp)?;
            return self.split.record_prefilter(rec, &i.dp, &i.cube, &p);
        };
        // The mirror from the whole map; the rest from the residual plus lights.
        match (residual, &prep.residual_grid) {
            (ResidualFrom::Clamp(threshold), _) if from.mapping != Mapping::Cube => {
                // One read of the source for both paraboloids, premultiplied.
                self.convert
                    .record_split(rec, from, (&i.dp, rdp), *threshold, &c)?;
                self.mip.record_premultiplied(rec, &i.dp)?;
                self.mip.record_premultiplied(rec, rdp)?;
            }
            (ResidualFrom::Clamp(threshold), _) => {
                self.convert.record(rec, from, &i.dp, &c)?;
                self.mip.record(rec, &i.dp)?;
                self.clamp.record(rec, src, *threshold)?;
                self.convert.record(rec, src, rdp, &c)?;
                self.mip.record(rec, rdp)?;
            }
            (ResidualFrom::Grid(r), Some(g)) => {
                self.convert.record(rec, from, &i.dp, &c)?;
                self.mip.record(rec, &i.dp)?;
                r.record_upload(rec, g)?;
                self.convert.record(rec, r, rdp, &c)?;
                self.mip.record(rec, rdp)?;
            }
            (ResidualFrom::Grid(_), None) => {
                return Err(Error::Invalid(
                    "bake: a residual image without its grid".into(),
                ))
            }
        }
        self.split
            .record_prefilter_levels(rec, &i.dp, &i.cube, &p, 0..1)?;
        self.split
            .record_prefilter_levels(rec, rdp, &i.cube, &p, 1..opts.specular_levels)?;
        for k in 1..opts.specular_levels {
            let alpha = level_alpha(k, opts.specular_levels);
            self.lights
                .record(rec, lights, LightKernel::Ggx { alpha }, &i.cube, k)?;
        }
        Ok(())
    }

    /// The split-sum DFG table (height-correlated Smith unless `correlated` is false), row
    /// √α = j/(size − 1) after row, (A, B) per entry.
    pub fn dfg(&self, size: u32, correlated: bool) -> Result<Vec<[f32; 2]>> {
        self.dfg_at(size, correlated, DfgAxes::Endpoints)
    }

    /// [`Baker::dfg`] with its entries where `axes` puts them.
    pub fn dfg_at(&self, size: u32, correlated: bool, axes: DfgAxes) -> Result<Vec<[f32; 2]>> {
        Ok(self.split.run_dfg_at(size, correlated, axes)?.value)
    }
}

/// A scoped thread's result, its panic resumed on this thread.
fn join<T>(h: std::thread::ScopedJoinHandle<'_, Result<T>>) -> Result<T> {
    h.join().unwrap_or_else(|p| std::panic::resume_unwind(p))
}
