//! Rendering a [`Scene`]: runs exactly the passes its [`plan`] lists, and records what each
//! cost.

use crate::abi::brdf::technique;
use crate::abi::split_sum;
use crate::error::{Error, Result};
use crate::gpu::{Buffer, Context, Recorder, Timing, Usage};
use crate::math::brdf::Brdf;
use crate::math::convert::{latlong_halved, paraboloid_source_halves, residual_edge_points};
use crate::math::filter::Kernel;
use crate::math::fis::default_dp_size;
use crate::math::lights::{extract_each, light_sh, lobe_scale, resolves, ExtractOptions};
use crate::math::sh::Window;
use crate::math::sh_brdf::ViewGrid;
use crate::math::split_sum::chain_norm;
use crate::math::{sh, Mapping, Orientation};
use crate::passes::gbuffer::{brdf_bits, shape_record, target, GBuffer, GpuObject};
use crate::passes::mc::{McEnv, McOptions};
use crate::passes::sh_project::Subgroups;
use crate::passes::shade::{Footprint, Rotation, ShadeCode, ShadeInputs};
use crate::passes::GpuLights;
use crate::passes::ShBrdfProjector;
use crate::passes::{
    BruteFilter, ConvertOptions, Converter, GBufferPass, GpuEnvMap, MipChain, MonteCarlo,
    ShProjector, Shade,
};
use crate::passes::{PrefilterOptions, SplitSum};
use crate::scene::{
    plan, LightsMode, LookupFilter, PassKind, Plan, Scene, SceneObject, SplitSumSettings,
    Technique, DEFAULT_FIS_BIAS, DEFAULT_FIS_BIAS_RESIDUAL,
};
use crate::EnvMap;
use ash::vk;
use gpu_allocator::MemoryLocation;
use std::cell::OnceCell;
use std::path::Path;

/// The GPU time of one pass of a render.
#[derive(Clone, Debug)]
pub struct PassRecord {
    /// Which pass.
    pub kind: PassKind,
    /// Its timestamp spans (empty where the device has no timestamps).
    pub timings: Vec<Timing>,
}

impl PassRecord {
    /// Total milliseconds.
    pub fn ms(&self) -> f64 {
        self.timings.iter().map(|t| t.ms).sum()
    }
}

/// What a render produced.
pub struct Rendered {
    /// The frame, linear RGB (a one-layer map of the camera's size).
    pub frame: EnvMap,
    /// One record per pass run, in order.
    pub records: Vec<PassRecord>,
    /// The plan it followed.
    pub plan: Plan,
    /// Monte Carlo samples per pixel and the final relative error estimate, if MC ran.
    pub mc: Option<(u32, Option<f64>)>,
    /// Host milliseconds spent extracting lights, then preparing them for the GPU (texel
    /// quadratures, the light tree, clusters, the upload's list), where the scene extracted
    /// any.
    pub lights_ms: Option<[f64; 2]>,
}

impl Rendered {
    /// The distinct passes that ran, in order of first run.
    pub fn kinds(&self) -> Vec<PassKind> {
        let mut v: Vec<PassKind> = Vec::new();
        for r in &self.records {
            if !v.contains(&r.kind) {
                v.push(r.kind);
            }
        }
        v
    }
}

/// Loads the scene's environment (relative to `base`), with its intensity applied.
pub fn load_environment(scene: &Scene, base: &Path) -> Result<EnvMap> {
    let env = &scene.environment;
    let mapping = match &env.mapping {
        Some(m) => Some(Mapping::parse(m).ok_or_else(|| {
            Error::Invalid(format!(
                "environment mapping '{m}' is not one of latlong, angular, cube, dual-paraboloid"
            ))
        })?),
        None => None,
    };
    let path = base.join(&env.file);
    let mut map = crate::io::load(
        &path,
        &crate::io::LoadOptions {
            mapping,
            ..Default::default()
        },
    )?;
    if env.intensity != 1.0 {
        let k = env.intensity as f32;
        for t in &mut map.texels {
            *t = t.map(|c| c * k);
        }
    }
    Ok(map)
}

/// Side of `scene`'s FIS dual paraboloid: the scene's `[fis] size`; else only as fine as its
/// lobes read ([`crate::math::fis::dp_size_for`], at most [`default_dp_size`]) where nothing
/// else reads the chain's fine levels (no split-sum, no footprint-filtered mirror, no
/// background filtered by request or seen through a perspective camera) and the lat-long
/// source converts to that size by exact footprint areas, so that its power is kept; else
/// [`default_dp_size`].
pub fn fis_dp_size(scene: &Scene, env: &EnvMap) -> u32 {
    if let Some(s) = scene.fis.size {
        return s;
    }
    let full = default_dp_size(env);
    // The footprint lookups a chain would serve (mirrors, the background) read its finest levels.
    let footprint = footprint_of(scene, true, false);
    let split_sum = scene
        .objects
        .iter()
        .any(|o| matches!(o.material.technique(), Technique::SplitSum));
    let Ok(world_to_file) = scene.environment.orientation().checked_world_to_file() else {
        return full;
    };
    if split_sum || footprint.mirror || footprint.background || env.mapping != Mapping::LatLong {
        return full;
    }
    let lobes = scene
        .objects
        .iter()
        .filter_map(|o| match o.material.technique() {
            Technique::Fis { samples, bias, .. } => {
                // The residual's default bias reads finer than the whole map's.
                let bias = bias.unwrap_or(DEFAULT_FIS_BIAS.min(DEFAULT_FIS_BIAS_RESIDUAL));
                Some(crate::math::fis::dp_size_for(
                    &o.material.kind,
                    samples,
                    bias,
                ))
            }
            _ => None,
        })
        .max();
    let Some(mut size) = lobes else {
        return full;
    };
    while size < full
        && !crate::math::convert::area_serves(
            env.width,
            env.height,
            Mapping::DualParaboloid,
            size,
            world_to_file,
        )
    {
        size *= 2;
    }
    size.min(full)
}

/// The GPU record of a scene object; `data_offset` locates its SH coefficients or its
/// prefiltered map (0 for other techniques).
pub fn object_record(o: &SceneObject, data_offset: u32) -> GpuObject {
    object_record_with(o, data_offset, 0)
}

/// [`object_record`] with the offset of the object's SH-BRDF table too (in floats).
pub fn object_record_with(o: &SceneObject, data_offset: u32, table_offset: u32) -> GpuObject {
    let mut g = shape_record(&o.shape);
    let m = &o.material;
    let brdf = m.kind;
    let p = brdf.params();
    let a = m.albedo;
    let off = data_offset as f32;
    let (tech, samples, extra) = match m.technique() {
        Technique::Lookup => (technique::LOOKUP, 0, [0.0; 4]),
        Technique::Fis {
            samples,
            bias,
            rotate,
        } => (
            technique::FIS,
            samples,
            [
                bias.unwrap_or(DEFAULT_FIS_BIAS) as f32,
                0.0,
                0.0,
                rotate as u32 as f32,
            ],
        ),
        Technique::Sh { order } => (technique::SH, 0, [0.0, off, order as f32, 0.0]),
        Technique::Prefiltered { size } => {
            (technique::PREFILTERED, 0, [0.0, off, size as f32, 0.0])
        }
        Technique::Mc { .. } => (technique::MC, 0, [0.0; 4]),
        // The chain's last lod and the DFG table are set by the render (see split_record).
        Technique::SplitSum => (technique::SPLIT_SUM, 0, [0.0; 4]),
        Technique::ShBrdf { order, grid, .. } => (
            technique::SH_BRDF,
            0,
            [grid as f32, off, order as f32, table_offset as f32],
        ),
    };
    g.albedo = [a[0] as f32, a[1] as f32, a[2] as f32, tech as f32];
    g.brdf = [brdf.id() as f32, p[0] as f32, p[1] as f32, samples as f32];
    g.extra = extra;
    g
}

/// Sets a split-sum object's record: the chain's `levels`, its DFG table (`dfg_size` a side)
/// at entry `dfg_offset` of the tables, and its `taps` per pixel (brdf.w).
pub fn split_record(g: &mut GpuObject, levels: u32, dfg_offset: u32, dfg_size: u32, taps: u32) {
    g.brdf[3] = taps as f32;
    g.extra = [
        levels.saturating_sub(1) as f32,
        dfg_offset as f32,
        dfg_size as f32,
        0.0,
    ];
}

/// Side of the split-sum chain: the scene's, or the FIS paraboloid's up to
/// [`split_sum::DEFAULT_SIZE`], but at least enough that the coarsest of `levels` keeps
/// [`split_sum::MIN_LEVEL_SIZE`] texels a side.
pub fn split_size(settings: &SplitSumSettings, dp_size: u32) -> u32 {
    settings.size.unwrap_or_else(|| {
        dp_size
            .min(split_sum::DEFAULT_SIZE)
            .max(split_sum::MIN_LEVEL_SIZE << settings.levels.saturating_sub(1))
    })
}

/// Directions on which SH lighting's ringing is measured: a 64 × 32 lat-long grid's centres.
fn ringing_directions() -> Vec<glam::DVec3> {
    let (w, h) = (64u32, 32u32);
    (0..w * h)
        .map(|k| {
            Mapping::LatLong.coord_to_dir(crate::math::Coord {
                layer: 0,
                u: ((k % w) as f64 + 0.5) / w as f64,
                v: ((k / w) as f64 + 0.5) / h as f64,
            })
        })
        .collect()
}

/// Renders scenes: holds each pass, built the first time a scene needs it and reused by
/// every later render on the same context.
pub struct Renderer {
    ctx: Context,
    converter: OnceCell<Converter>,
    mip: OnceCell<MipChain>,
    sh: OnceCell<ShProjector>,
    brute: OnceCell<BruteFilter>,
    gbuffer: OnceCell<GBufferPass>,
    mc: OnceCell<MonteCarlo>,
    shade: OnceCell<Shade>,
    sh_brdf: OnceCell<ShBrdfProjector>,
    split: OnceCell<SplitSum>,
    sh_rotation: Rotation,
    subgroups: Subgroups,
    whole_shade: bool,
}

/// The pass in `cell`, built by `make` on first use.
fn pass<T>(cell: &OnceCell<T>, make: impl FnOnce() -> Result<T>) -> Result<&T> {
    if cell.get().is_none() {
        let _ = cell.set(make()?);
    }
    Ok(cell.get().unwrap_or_else(|| unreachable!("set above")))
}

/// Spans recorded per pass within one recording, to split its timings by pass.
struct Marks(Vec<(PassKind, usize, usize)>);

impl Marks {
    fn record<R>(
        &mut self,
        rec: &mut Recorder,
        kind: PassKind,
        f: impl FnOnce(&mut Recorder) -> Result<R>,
    ) -> Result<R> {
        let a = rec.spans();
        let r = f(rec)?;
        self.0.push((kind, a, rec.spans()));
        Ok(r)
    }

    fn split(&self, timings: &[Timing], into: &mut Vec<PassRecord>) {
        for &(kind, a, b) in &self.0 {
            into.push(PassRecord {
                kind,
                timings: timings
                    .get(a..b)
                    .map(<[Timing]>::to_vec)
                    .unwrap_or_default(),
            });
        }
    }
}

impl Renderer {
    /// A renderer on `ctx` (no pass is built yet).
    pub fn new(ctx: &Context) -> Renderer {
        Renderer {
            ctx: ctx.clone(),
            converter: OnceCell::new(),
            mip: OnceCell::new(),
            sh: OnceCell::new(),
            brute: OnceCell::new(),
            gbuffer: OnceCell::new(),
            mc: OnceCell::new(),
            shade: OnceCell::new(),
            sh_brdf: OnceCell::new(),
            split: OnceCell::new(),
            sh_rotation: Rotation::Zxzxz,
            subgroups: Subgroups::Auto,
            whole_shade: false,
        }
    }

    /// Whether passes built from now on may use subgroup operations (the default: where the
    /// device has them); [`Subgroups::Off`] tests the fallbacks. Passes already built keep
    /// theirs.
    pub fn set_subgroups(&mut self, subgroups: Subgroups) {
        self.subgroups = subgroups;
    }

    /// Shades every scene with the whole shade shader, where a scene of one technique would
    /// take the variant built for it ([`crate::passes::shade::module`]); for tests, which
    /// compare the two. Takes effect if the shade pass is not built yet.
    pub fn set_whole_shade(&mut self) {
        self.whole_shade = true;
    }

    /// Rotates SH-BRDF vectors with `rotation` from now on (the default is zxzxz).
    pub fn set_sh_rotation(&mut self, rotation: Rotation) {
        self.sh_rotation = rotation;
    }

    fn converter(&self) -> Result<&Converter> {
        pass(&self.converter, || Converter::new(&self.ctx))
    }

    /// Renders `scene` with `env` (from [`load_environment`]). Everything up to the shading
    /// is recorded into one submission and stays on the GPU; only SH coefficients (a few
    /// hundred bytes) and, for Monte Carlo on a map that is not lat-long, the converted map
    /// (its sampling tables are built on the CPU) come back to the host before shading.
    pub fn render(&self, scene: &Scene, env: &EnvMap) -> Result<Rendered> {
        scene.validate().map_err(Error::Invalid)?;
        let plan = plan(scene, env.mapping);
        let code = shade_code(scene, &plan);
        let shade = pass(&self.shade, || {
            let mut s = Shade::with_subgroups(&self.ctx, self.subgroups)?;
            if self.whole_shade {
                s.whole_shader_only();
            }
            Ok(s)
        })?;
        // The shade pipeline is the longest build (llvmpipe: 30-100 ms by variant, a compute
        // pass's 2-30): it builds on a second thread while this one builds the other passes,
        // extracts the lights and records and runs everything before the shading. So do the
        // dual paraboloid's conversion pipelines (llvmpipe: 36 ms), on a third.
        let dp = match plan.kinds().contains(&PassKind::DualParaboloid) {
            true => Some((self.converter()?, dp_convert_options(scene, env))),
            false => None,
        };
        std::thread::scope(|s| {
            let shade_build = s.spawn(|| shade.prepare_code(&code));
            let convert_build = s.spawn(|| match dp {
                // The pipelines that serve the whole map serve its halves too.
                Some((conv, opts)) => conv.prepare_for((env.mapping, env.width, env.height), &opts),
                None => Ok(()),
            });
            let joined = |what: &'static str| {
                move |r: std::thread::Result<Result<()>>| -> Result<()> {
                    r.map_err(|_| Error::Invalid(format!("building the {what} panicked")))?
                }
            };
            let builds = Builds {
                shade: Box::new(move || joined("shade pipeline")(shade_build.join())),
                convert: Box::new(move || joined("conversion pipelines")(convert_build.join())),
            };
            self.render_planned(scene, env, plan, shade, &code, dp.map(|d| d.1), builds)
        })
    }

    /// [`Renderer::render`] once the shade pipeline for `code`, and the conversion to the
    /// dual paraboloid with `dp_opts` where there is one, are being built.
    #[allow(clippy::too_many_arguments)]
    fn render_planned(
        &self,
        scene: &Scene,
        env: &EnvMap,
        plan: Plan,
        shade: &Shade,
        code: &ShadeCode,
        dp_opts: Option<ConvertOptions>,
        builds: Builds<'_>,
    ) -> Result<Rendered> {
        let ctx = &self.ctx;
        let kinds = plan.kinds();
        let needs = |k: PassKind| kinds.contains(&k);
        let orientation: Orientation = scene.environment.orientation();
        let mut records = Vec::new();
        let env_gpu = GpuEnvMap::new(ctx, "environment", env.mapping, env.width, env.height)?;

        // Build the passes first: pipeline creation is not GPU work.
        let sh_pass = if needs(PassKind::ShProjection) {
            Some(pass(&self.sh, || ShProjector::new(ctx, self.subgroups))?)
        } else {
            None
        };
        let dp_passes = if needs(PassKind::DualParaboloid) {
            Some((self.converter()?, pass(&self.mip, || MipChain::new(ctx))?))
        } else {
            None
        };
        let brute = if needs(PassKind::Prefilter) {
            Some(pass(&self.brute, || BruteFilter::new(ctx))?)
        } else {
            None
        };
        let gbuffer_pass = pass(&self.gbuffer, || GBufferPass::new(ctx))?;

        // SH: one projection at the highest order asked; each object gets its own truncation.
        let lmax = scene
            .objects
            .iter()
            .filter_map(|o| match o.material.technique() {
                Technique::Sh { order } | Technique::ShBrdf { order, .. } => Some(order),
                _ => None,
            })
            .max()
            .unwrap_or(2);

        // SH-BRDF tables, one per object, concatenated.
        let mut table_offsets = vec![0u32; scene.objects.len()];
        let mut tables: Vec<(Brdf, u32, ViewGrid, u32)> = Vec::new();
        let mut table_floats = 0usize;
        for (k, o) in scene.objects.iter().enumerate() {
            if let Technique::ShBrdf { order, grid, .. } = o.material.technique() {
                let g = ViewGrid { size: grid };
                table_offsets[k] = table_floats as u32;
                tables.push((o.material.kind, order, g, table_floats as u32));
                table_floats += ShBrdfProjector::table_floats(order, g);
            }
        }
        let brdf_pass = if needs(PassKind::ShBrdfTable) {
            Some(pass(&self.sh_brdf, || Ok(ShBrdfProjector::new(ctx)))?)
        } else {
            None
        };
        let table_buffer = match brdf_pass {
            Some(_) => Some(Buffer::new(
                ctx,
                "sh brdf tables",
                table_floats.max(4) as u64 * 4,
                vk::BufferUsageFlags::STORAGE_BUFFER,
                MemoryLocation::GpuOnly,
            )?),
            None => None,
        };
        let sh_out = match sh_pass {
            Some(_) => Some(Buffer::new(
                ctx,
                "sh coefficients",
                ShProjector::output_bytes(lmax),
                vk::BufferUsageFlags::TRANSFER_DST,
                MemoryLocation::GpuToCpu,
            )?),
            None => None,
        };
        // Lights: SH and prefiltered diffuse objects take the diffuse residual's SH or
        // irradiance map plus its light clusters' irradiance (a deep extraction, summed by
        // cells); FIS and split-sum objects the residual's paraboloid plus the light texels
        // under their lobes, prefiltered Phong objects the residual's Phong map plus the light
        // texels under their BRDF. The paraboloid (or a Phong map) keeps the whole map where a
        // mirror is read by FIS, or a lobe is too narrow for the light texels' quadrature
        // ([`resolves`]).
        let extracting = scene.environment.lights == LightsMode::Extract;
        let has = |f: &dyn Fn(&SceneObject) -> bool| scene.objects.iter().any(f);
        let on_chain = |o: &SceneObject| {
            matches!(
                o.material.technique(),
                Technique::Fis { .. } | Technique::SplitSum
            )
        };
        let sh_lights = extracting
            && sh_pass.is_some()
            && has(&|o| matches!(o.material.technique(), Technique::Sh { .. }));
        // Prefiltered irradiance maps too: the residual's map plus the lights' irradiance.
        let diffuse_prefiltered = |o: &SceneObject| {
            matches!(o.material.technique(), Technique::Prefiltered { .. })
                && matches!(o.material.kind, Brdf::Lambert)
        };
        let pre_lights = extracting && brute.is_some() && has(&diffuse_prefiltered);
        // Prefiltered Phong maps: the residual's map (the chain's extraction) plus the light
        // texels under each pixel's lobe, where the texels' nodes resolve it.
        let phong_prefiltered = |o: &SceneObject| {
            matches!(o.material.technique(), Technique::Prefiltered { .. })
                && matches!(o.material.kind, Brdf::Phong { .. })
        };
        let phong_lights = extracting && brute.is_some() && has(&phong_prefiltered);
        let dp_lights = dp_passes.is_some() && chain_takes_lights(scene);
        // The finest lobe on the chain the light texels' nodes must resolve.
        let finest_chain = scene
            .objects
            .iter()
            .filter(|o| on_chain(o))
            .filter_map(|o| lobe_scale(&o.material.kind))
            .fold(1.0, f64::min);
        let file_to_world = orientation.checked_world_to_file()?.transpose();
        // The chain's extraction, where its lobes are wide enough for the texels' nodes.
        // And the diffuse extraction: deeper, its texels summed by clusters. Both from one
        // pass over the map.
        // The filled residual serves filtered sampling and prefiltered Phong maps (read
        // bilinearly: Phong 64 on studio_small_08, 32², erred by 3.88% filled, 6.38% clamped);
        // footprint lookups alone keep the clamp, since they take light texels by shares
        // linearised over the pixel (a mirror on studio_small_08 erred by 3.52% filled, 2.57%
        // clamped).
        let chain_options = || {
            let mut o = scene.environment.extract_options();
            if !has(&on_chain) && !phong_lights {
                o.fill = None;
            }
            o
        };
        let asked: Vec<ExtractOptions> = [
            (dp_lights || phong_lights).then(chain_options),
            (sh_lights || pre_lights).then(|| scene.environment.diffuse_extract_options()),
        ]
        .into_iter()
        .flatten()
        .collect();
        let started = std::time::Instant::now();
        let each = extract_each(env, &asked);
        let extract_ms = 1e3 * started.elapsed().as_secs_f64();
        let lights_started = std::time::Instant::now();
        let mut each = each.into_iter();
        let chain_ex = (dp_lights || phong_lights)
            .then(|| each.next())
            .flatten()
            .filter(|e| !e.lights.is_empty());
        // No texel above the lights' threshold: the whole map is as sunless as a residual.
        let below_threshold = dp_lights && chain_ex.is_none();
        let dp_lights = dp_lights && chain_ex.as_ref().is_some_and(|e| resolves(e, finest_chain));
        // The prefiltered Phong objects that add the light texels: lobes the nodes resolve.
        let phong_lit: Vec<bool> = scene
            .objects
            .iter()
            .map(|o| {
                phong_prefiltered(o)
                    && chain_ex.as_ref().is_some_and(|e| {
                        lobe_scale(&o.material.kind).is_some_and(|s| resolves(e, s))
                    })
            })
            .collect();
        let chain_ex = chain_ex.filter(|_| dp_lights || phong_lit.contains(&true));
        // The finest lobe that reads the light texels.
        let finest = scene
            .objects
            .iter()
            .zip(&phong_lit)
            .filter(|&(o, &lit)| lit || (dp_lights && on_chain(o)))
            .filter_map(|(o, _)| lobe_scale(&o.material.kind))
            .fold(1.0, f64::min);
        let diffuse_ex = each.next().filter(|e| !e.lights.is_empty());
        let (sh_lights, pre_lights) = match diffuse_ex {
            Some(_) => (sh_lights, pre_lights),
            None => (false, false),
        };
        let lights = GpuLights::of_extractions(
            ctx,
            env,
            chain_ex.as_ref(),
            diffuse_ex.as_ref(),
            file_to_world,
            finest,
        )?;
        let lights_ms =
            (!asked.is_empty()).then(|| [extract_ms, 1e3 * lights_started.elapsed().as_secs_f64()]);
        let residual_map = |name| GpuEnvMap::new(ctx, name, env.mapping, env.width, env.height);
        // The paraboloid's source: the residual where the chain takes the lights, else the
        // map. The residual is halved where that is still as fine as the paraboloid's finest
        // texels: its brightest texels are the lights' threshold τ, whereas a sun left in the
        // chain, moved within its 2 × 2 block, erred 6× the whole map's chain (tests/fis.rs).
        let dp_source = match (&dp_opts, &chain_ex) {
            (Some(opts), Some(ex)) if dp_lights && dp_source_halves(env, opts.size) => {
                let map = latlong_halved(&ex.residual);
                let gpu = GpuEnvMap::new(
                    ctx,
                    "fis paraboloid source",
                    map.mapping,
                    map.width,
                    map.height,
                )?;
                Some((map, gpu))
            }
            _ => None,
        };
        // The whole residual where a Phong map or the paraboloid reads it.
        let chain_residual = match &chain_ex {
            Some(ex) if phong_lit.contains(&true) || (dp_lights && dp_source.is_none()) => {
                Some((ex, residual_map("environment residual")?))
            }
            _ => None,
        };
        // The diffuse residual's map, where prefiltered irradiance maps are filtered from it.
        // SH objects need no projection of it: the whole map's coefficients less the light
        // texels' ([`light_sh`]) are its coefficients.
        let diffuse_residual = match &diffuse_ex {
            Some(ex) if pre_lights => Some((ex, residual_map("diffuse residual")?)),
            _ => None,
        };
        let lights_sh = match &diffuse_ex {
            Some(ex) if sh_lights => Some(light_sh(env, ex, file_to_world, lmax)),
            _ => None,
        };

        // FIS: the dual paraboloid and its MIP chain.
        let dp = match (dp_passes, &dp_opts) {
            (Some(_), Some(opts)) => {
                let (w, h) = Mapping::DualParaboloid.extent_for_size(opts.size);
                Some((
                    GpuEnvMap::with_mips(ctx, "fis paraboloid", Mapping::DualParaboloid, w, h)?,
                    opts.size,
                ))
            }
            _ => None,
        };

        // Prefiltered maps, one per distinct (kernel, size, of the residual or not),
        // concatenated into one buffer on the GPU; each object's record holds its map's offset.
        let mut pre_offsets = vec![0u32; scene.objects.len()];
        let mut pre_maps: Vec<(Kernel, GpuEnvMap, u32, bool)> = Vec::new();
        let mut pre_texels = 0u32;
        if brute.is_some() {
            let mut made: Vec<(u64, u32, bool, u32)> = Vec::new();
            for (k, o) in scene.objects.iter().enumerate() {
                let Technique::Prefiltered { size } = o.material.technique() else {
                    continue;
                };
                let kernel = match o.material.kind {
                    Brdf::Phong { n } => Kernel::Phong { n },
                    _ => Kernel::Cosine,
                };
                let key = match kernel {
                    Kernel::Phong { n } => n.to_bits(),
                    Kernel::Cosine => u64::MAX,
                };
                // Maps of the residual where the lights are added per pixel.
                let lit = (pre_lights && diffuse_prefiltered(o)) || phong_lit[k];
                if let Some(&(.., off)) = made
                    .iter()
                    .find(|m| m.0 == key && m.1 == size && m.2 == lit)
                {
                    pre_offsets[k] = off;
                    continue;
                }
                let (w, h) = Mapping::LatLong.extent_for_size(size);
                let map = GpuEnvMap::new(ctx, "prefiltered", Mapping::LatLong, w, h)?;
                made.push((key, size, lit, pre_texels));
                pre_offsets[k] = pre_texels;
                pre_maps.push((kernel, map, pre_texels, lit));
                pre_texels += w * h;
            }
        }
        let pre_buffer = match brute {
            Some(_) => Some(Buffer::new(
                ctx,
                "prefiltered maps",
                (pre_texels.max(1) as u64) * 16,
                vk::BufferUsageFlags::STORAGE_BUFFER | vk::BufferUsageFlags::TRANSFER_DST,
                MemoryLocation::GpuOnly,
            )?),
            None => None,
        };

        // Split-sum: one prefiltered chain, one DFG table per Smith form in use.
        let split = if needs(PassKind::SplitSum) {
            let p = pass(&self.split, || SplitSum::new(ctx))?;
            let ss = &scene.split_sum;
            let dp_size = dp.as_ref().map(|d| d.1).unwrap_or(split_sum::DEFAULT_SIZE);
            let chain = SplitSum::chain(ctx, split_size(ss, dp_size), ss.levels)?;
            let mut forms: Vec<bool> = Vec::new();
            for o in &scene.objects {
                if let (Technique::SplitSum, Brdf::Ggx { correlated, .. }) =
                    (o.material.technique(), o.material.kind)
                {
                    if !forms.contains(&correlated) {
                        forms.push(correlated);
                    }
                }
            }
            let tables = Buffer::new(
                ctx,
                "dfg tables",
                (forms.len() * SplitSum::dfg_floats(ss.dfg_size)) as u64 * 4,
                vk::BufferUsageFlags::STORAGE_BUFFER,
                MemoryLocation::GpuOnly,
            )?;
            Some((p, chain, tables, forms))
        } else {
            None
        };

        let mut gbuf_objects: Vec<GpuObject> = scene
            .objects
            .iter()
            .enumerate()
            .map(|(k, o)| object_record_with(o, pre_offsets[k], table_offsets[k]))
            .collect();
        if let Some((_, chain, _, forms)) = &split {
            let ss = &scene.split_sum;
            for (g, o) in gbuf_objects.iter_mut().zip(&scene.objects) {
                if let (Technique::SplitSum, Brdf::Ggx { correlated, .. }) =
                    (o.material.technique(), o.material.kind)
                {
                    let form = forms.iter().position(|&c| c == correlated).unwrap_or(0);
                    let entries = (form * SplitSum::dfg_floats(ss.dfg_size) / 2) as u32;
                    split_record(g, chain.mips(), entries, ss.dfg_size, ss.taps);
                }
            }
        }
        for ((g, o), &phong) in gbuf_objects.iter_mut().zip(&scene.objects).zip(&phong_lit) {
            // extra.w = 1: the shader adds the light clusters' irradiance, or the light texels
            // under the Phong BRDF (extra.x: its lobe's scale).
            if pre_lights && diffuse_prefiltered(o) {
                g.extra[3] = 1.0;
            }
            if let (true, Some(scale)) = (phong, lobe_scale(&o.material.kind)) {
                g.extra[0] = scale as f32;
                g.extra[3] = 1.0;
            }
        }
        if dp_lights {
            for (g, o) in gbuf_objects.iter_mut().zip(&scene.objects) {
                match (o.material.technique(), o.material.kind) {
                    // extra.y = 1: add the light texels; extra.z: the lobe's scale; extra.x:
                    // the residual's default bias where the scene sets none.
                    (Technique::Fis { bias, .. }, kind) => {
                        if let Some(scale) = lobe_scale(&kind) {
                            g.extra[1] = 1.0;
                            g.extra[2] = scale as f32;
                            g.extra[0] = bias.unwrap_or(DEFAULT_FIS_BIAS_RESIDUAL) as f32;
                        }
                    }
                    // extra.w = 1/∫K at the material's α.
                    (Technique::SplitSum, Brdf::Ggx { alpha, .. }) => {
                        g.extra[3] = (1.0 / chain_norm(alpha)) as f32;
                    }
                    _ => {}
                }
            }
        }
        let mut gbuf = GBuffer::new(ctx, scene.camera.width, scene.camera.height, &gbuf_objects)?;
        gbuf.camera = Some(scene.camera);

        // Everything before shading, in one submission.
        let mut marks = Marks(Vec::new());
        let ((), t) = ctx.run("rendering: inputs", |rec| {
            env_gpu.record_upload(rec, env)?;
            if let (Some(p), Some(out)) = (sh_pass, &sh_out) {
                marks.record(rec, PassKind::ShProjection, |rec| {
                    p.record(rec, &env_gpu, lmax, &orientation, out)
                })?;
                rec.use_buffer(out, Usage::HostRead);
            }
            if let Some((ex, map)) = &chain_residual {
                map.record_upload(rec, &ex.residual)?;
            }
            if let Some((map, gpu)) = &dp_source {
                gpu.record_upload(rec, map)?;
            }
            if let Some((ex, map)) = &diffuse_residual {
                map.record_upload(rec, &ex.residual)?;
            }
            if let (Some(p), Some(buf)) = (brdf_pass, &table_buffer) {
                for (brdf, order, grid, off) in &tables {
                    marks.record(rec, PassKind::ShBrdfTable, |rec| {
                        p.record(rec, brdf, *order, *grid, buf, *off)
                    })?;
                }
            }
            if let (Some((conv, mip)), Some((map, _)), Some(opts)) = (dp_passes, &dp, &dp_opts) {
                // After the uploads' staging copies, which this thread makes meanwhile.
                (builds.convert)()?;
                let source = match (&dp_source, &chain_residual) {
                    (Some((_, gpu)), _) => gpu,
                    (None, Some((_, res))) if dp_lights => res,
                    _ => &env_gpu,
                };
                // A residual holds no sun for the rim's chords to misplace: fewer points (as
                // predicted for the pipeline built meanwhile, unless the lobes were too narrow
                // for the lights found, which leaves them in the chain).
                let opts = ConvertOptions {
                    edge_points: (dp_lights || below_threshold)
                        .then(|| residual_edge_points(opts.size)),
                    ..*opts
                };
                marks.record(rec, PassKind::DualParaboloid, |rec| {
                    conv.record(rec, source, map, &opts)
                })?;
                marks.record(rec, PassKind::MipChain, |rec| mip.record(rec, map))?;
                if let Some((p, chain, tables, forms)) = &split {
                    let ss = &scene.split_sum;
                    marks.record(rec, PassKind::SplitSum, |rec| {
                        for (i, &correlated) in forms.iter().enumerate() {
                            let off = (i * SplitSum::dfg_floats(ss.dfg_size)) as u32;
                            p.record_dfg(rec, ss.dfg_size, correlated, tables, off)?;
                        }
                        let opts = PrefilterOptions {
                            levels: ss.levels,
                            samples: ss.samples,
                            bias: ss.bias.unwrap_or(DEFAULT_FIS_BIAS),
                        };
                        p.record_prefilter(rec, map, chain, &opts)
                    })?;
                }
            }
            if let (Some(b), Some(buf)) = (brute, &pre_buffer) {
                for (kernel, map, off, lit) in &pre_maps {
                    let residual = match kernel {
                        Kernel::Cosine => &diffuse_residual,
                        Kernel::Phong { .. } => &chain_residual,
                    };
                    let source = match residual {
                        Some((_, res)) if *lit => res,
                        _ => &env_gpu,
                    };
                    marks.record(rec, PassKind::Prefilter, |rec| {
                        b.record(rec, source, &orientation, *kernel, map)
                    })?;
                    rec.copy_image_to_buffer(&map.image, 0, buf, *off as u64 * 16);
                }
            }
            marks.record(rec, PassKind::GBuffer, |rec| {
                gbuffer_pass.record(rec, &scene.camera, &gbuf)
            })
        })?;
        marks.split(&t, &mut records);

        // SH coefficients: each object's truncation, with Â_l folded in.
        let mut sh_coeffs: Vec<[f64; 3]> = Vec::new();
        let mut ringing = Vec::new();
        if let Some(out) = &sh_out {
            let read = |out: &Buffer| -> Vec<[f64; 3]> {
                let flat: Vec<f32> = out.read(sh::count(lmax) * 3);
                flat.chunks_exact(3)
                    .map(|c| [c[0] as f64, c[1] as f64, c[2] as f64])
                    .collect()
            };
            let c = read(out);
            // The residual's: the whole map's less the light texels'.
            let c_res: Option<Vec<[f64; 3]>> = lights_sh.as_ref().map(|l| {
                c.iter()
                    .zip(l)
                    .map(|(a, b)| [a[0] - b[0], a[1] - b[1], a[2] - b[2]])
                    .collect()
            });
            let mut objects = gbuf_objects.clone();
            for (k, o) in scene.objects.iter().enumerate() {
                match o.material.technique() {
                    Technique::Sh { order } => {
                        objects[k] = object_record(o, sh_coeffs.len() as u32);
                        let c = match &c_res {
                            Some(r) => {
                                // extra.w = 1: the shader adds the light clusters.
                                objects[k].extra[3] = 1.0;
                                r
                            }
                            None => &c,
                        };
                        sh_coeffs.extend(sh::irradiance_coeffs(&c[..sh::count(order)]));
                    }
                    Technique::ShBrdf { order, window, .. } => {
                        objects[k] =
                            object_record_with(o, sh_coeffs.len() as u32, table_offsets[k]);
                        let radiance = &c[..sh::count(order)];
                        let w = match window {
                            Some(width) => Window::Hanning { width },
                            None => Window::None,
                        };
                        let lit = w.apply(radiance);
                        let neg = sh::negativity(&lit, &ringing_directions());
                        if neg.fraction > 0.0 {
                            ringing.push(format!(
                                "ringing: object {k}'s order-{order} lighting ({w:?}) is negative \
                                 on {:.1}% of the sphere, down to {:.2}% of its mean",
                                100.0 * neg.fraction,
                                100.0 * neg.worst
                            ));
                        }
                        sh_coeffs.extend(lit);
                    }
                    _ => {}
                }
            }
            gbuf.objects.write(&objects);
        }

        // Monte Carlo: one accumulation for every MC material, at the most samples any asks.
        let mut mc = None;
        let mut mc_summary = None;
        if needs(PassKind::MonteCarlo) {
            let (samples, error) = scene
                .objects
                .iter()
                .filter_map(|o| match o.material.technique() {
                    Technique::Mc { samples, error } => Some((samples, error)),
                    _ => None,
                })
                .fold((0, None::<f64>), |(s, e), (s2, e2)| {
                    (
                        s.max(s2),
                        match (e, e2) {
                            (Some(a), Some(b)) => Some(a.min(b)),
                            (a, b) => a.or(b),
                        },
                    )
                });
            let (mc_env, t) = McEnv::for_map(ctx, self.converter()?, env, &env_gpu, &orientation)?;
            if !t.is_empty() {
                records.push(PassRecord {
                    kind: PassKind::LatLong,
                    timings: t,
                });
            }
            let mc_pass = pass(&self.mc, || MonteCarlo::new(ctx))?;
            let (res, t) = mc_pass.run(
                &gbuf,
                &mc_env,
                &McOptions {
                    samples,
                    target_error: error,
                    mis: scene.mc.mis,
                    seed: scene.mc.seed,
                    shadows: scene.shadows,
                    per_frame: scene.mc.per_frame,
                },
            )?;
            records.push(PassRecord {
                kind: PassKind::MonteCarlo,
                timings: t,
            });
            mc_summary = Some((res.samples, res.error));
            mc = Some(res);
        }

        let frame = target(ctx, "shaded frame", gbuf.width, gbuf.height)?;
        let inputs = ShadeInputs {
            env: &env_gpu,
            orientation,
            sh: (!sh_coeffs.is_empty()).then_some(&sh_coeffs[..]),
            dp: dp.as_ref().map(|d| &d.0),
            prefiltered: pre_buffer.as_ref(),
            mc: mc.as_ref().map(|m| (&m.accum, m.samples)),
            brdf_sh: table_buffer.as_ref(),
            sh_rotation: self.sh_rotation,
            split: split.as_ref().map(|s| (&s.1, &s.2)),
            shadows: scene.shadows,
            lights: lights.as_ref(),
            footprint: footprint_of(scene, dp.is_some(), dp_lights),
        };
        // The pipeline built from the plan's code is the one the draw takes.
        debug_assert_eq!(
            crate::passes::shade::code_mask(&inputs, &gbuf),
            crate::passes::shade::code_bits(code)
        );
        (builds.shade)()?;
        let mut marks = Marks(Vec::new());
        let (readback, t) = ctx.run("rendering: shading", |rec| {
            marks.record(rec, PassKind::Shade, |rec| {
                shade.record(rec, &gbuf, &inputs, &frame)
            })?;
            frame.record_download(rec, 0)
        })?;
        marks.split(&t, &mut records);
        let frame = EnvMap::new(
            Mapping::LatLong,
            gbuf.width,
            gbuf.height,
            readback
                .read()
                .into_iter()
                .map(|t| [t[0], t[1], t[2]])
                .collect(),
        );
        if let Some(k) = frame
            .texels
            .iter()
            .position(|t| t.iter().any(|c| !c.is_finite()))
        {
            return Err(Error::Invalid(format!(
                "pixel ({}, {}) of the frame is not finite: {:?}",
                k as u32 % frame.width,
                k as u32 / frame.width,
                frame.texels[k]
            )));
        }
        let mut plan = plan;
        plan.notes.extend(ringing);
        Ok(Rendered {
            frame,
            records,
            plan,
            mc: mc_summary,
            lights_ms,
        })
    }
}

/// The pipeline builds a render starts on other threads; each call waits for its build.
struct Builds<'a> {
    shade: Box<dyn FnOnce() -> Result<()> + 'a>,
    convert: Box<dyn FnOnce() -> Result<()> + 'a>,
}

/// How `scene`'s FIS dual paraboloid is converted from `env`: [`fis_dp_size`], nearest reads
/// where [`chain_of_texel_means`], the residual's points per texel edge where the chain is to
/// take the lights ([`chain_takes_lights`]; the record takes the default's where the lights
/// found are too small for its lobes' quadrature and so stay in the chain).
fn dp_convert_options(scene: &Scene, env: &EnvMap) -> ConvertOptions {
    let size = fis_dp_size(scene, env);
    ConvertOptions {
        to: Mapping::DualParaboloid,
        size,
        orientation: scene.environment.orientation(),
        supersample: None,
        nearest: chain_of_texel_means(scene),
        edge_points: chain_takes_lights(scene).then(|| residual_edge_points(size)),
    }
}

/// Whether `scene`'s dual-paraboloid chain is to hold the residual of extracted lights, the
/// light texels added by the shader: lights extracted, the chain read by FIS, split-sum or
/// footprint lookups, and every chain object's lobe of a known scale (the extraction may still
/// find no light, or none its lobes' quadrature resolves).
fn chain_takes_lights(scene: &Scene) -> bool {
    let on_chain = |o: &SceneObject| {
        matches!(
            o.material.technique(),
            Technique::Fis { .. } | Technique::SplitSum
        )
    };
    // Footprint lookups read the chain too, and add the light texels they cover.
    let footprint_reads = scene.environment.filter != LookupFilter::Point;
    scene.environment.lights == LightsMode::Extract
        && (scene.objects.iter().any(on_chain) || footprint_reads)
        && !scene
            .objects
            .iter()
            .any(|o| on_chain(o) && lobe_scale(&o.material.kind).is_none())
}

/// Whether the FIS paraboloid of side `size` is converted from `env`'s residual halved
/// ([`paraboloid_source_halves`]; lat-long maps only).
fn dp_source_halves(env: &EnvMap, size: u32) -> bool {
    env.mapping == Mapping::LatLong && paraboloid_source_halves(env.width, env.height, size)
}

/// The shade code `scene`'s draw takes under `plan`: known before any input exists, so that
/// its pipeline builds while the inputs are made.
fn shade_code(scene: &Scene, plan: &Plan) -> ShadeCode {
    let kinds = plan.kinds();
    let needs = |k: PassKind| kinds.contains(&k);
    let fis = needs(PassKind::DualParaboloid);
    ShadeCode {
        fis,
        sh: needs(PassKind::ShProjection),
        prefiltered: needs(PassKind::Prefilter),
        mc: needs(PassKind::MonteCarlo),
        sh_brdf: needs(PassKind::ShBrdfTable),
        split_sum: needs(PassKind::SplitSum),
        footprint: {
            let f = footprint_of(scene, fis, false);
            f.mirror || f.background
        },
        shadows: scene.shadows,
        brdfs: brdf_bits(scene.objects.iter().map(|o| o.material.kind.id())),
    }
}

/// Whether `scene`'s dual paraboloid is converted with nearest-texel reads (the means of the
/// source's texels): where footprint-filtered mirrors read it, or the background is asked to
/// be; a bilinear reconstruction spreads a bright texel into its neighbours' pixels.
pub fn chain_of_texel_means(scene: &Scene) -> bool {
    let filter = scene.environment.filter;
    filter == LookupFilter::Footprint
        || (filter == LookupFilter::Auto
            && scene
                .objects
                .iter()
                .any(|o| matches!(o.material.technique(), Technique::Lookup)))
}

/// Which lookups of `scene` are footprint-filtered, given whether the render builds the
/// dual-paraboloid chain and whether that chain holds the residual of extracted lights (the
/// mirror flag only where a mirror is drawn, so that the shade pipeline keeps no footprint
/// code it would not run). Under `filter = "auto"` an orthographic camera's background reads
/// the map itself: each of its pixels sees one direction, so there is no footprint to filter.
pub fn footprint_of(scene: &Scene, chain: bool, residual: bool) -> Footprint {
    let filter = scene.environment.filter;
    let ortho = matches!(
        scene.camera.projection,
        crate::math::camera::Projection::Orthographic { .. }
    );
    let mirrors = scene
        .objects
        .iter()
        .any(|o| matches!(o.material.technique(), Technique::Lookup));
    Footprint {
        mirror: chain && mirrors && filter != LookupFilter::Point,
        background: chain
            && (filter == LookupFilter::Footprint || (filter == LookupFilter::Auto && !ortho)),
        lights: chain && residual,
    }
}

/// Renders `scene` with `env` (from [`load_environment`]) on `ctx`, with a renderer of its
/// own (see [`Renderer`] to reuse the passes across renders).
pub fn render(ctx: &Context, scene: &Scene, env: &EnvMap) -> Result<Rendered> {
    Renderer::new(ctx).render(scene, env)
}
