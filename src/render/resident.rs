//! The resident path: a scene rendered from an environment that lives on the GPU (an image
//! the engine owns, rewritten every frame), recorded into the caller's command buffer with
//! nothing read back, nothing submitted and, after the first frame, nothing allocated.
//!
//! [`Renderer::resident`] plans the scene for a map's shape, makes every resource once and
//! computes what no environment changes (the SH-BRDF and DFG tables, in one submission of its
//! own); [`Renderer::record_resident`] records a frame: the image copied with every texel that
//! is no finite, non-negative radiance zeroed and counted, then SH projection and packing, the
//! paraboloid and its chain, split-sum's levels, prefiltered maps, the G-buffer and the
//! shading, each from the image given, into [`Resident::frame`].

use super::inputs::{self, Inputs, Work};
use super::lights::Lit;
use super::plan::{plan_for, PassKind, Plan};
use super::records::{gpu_objects, Marks};
use super::shading::{self, Shading};
use super::{Job, Rendered, Renderer};
use crate::error::{Error, Result};
use crate::gpu::{Buffer, FrameCache, Recorder, Timed};
use crate::math::lights::{cells_for_rho, largest_rho, resolves_rho, CLUSTER_GRID};
use crate::math::Mapping;
use crate::passes::gbuffer::{target, GBuffer};
use crate::passes::map::Sanitizer;
use crate::passes::{
    time_slices, ConvertPlan, Extractor, GpuEnvMap, GpuExtraction, GpuLights, LevelLayers,
    LevelSamples, ShProjector, Subgroups,
};
use crate::scene::MapShape;
use crate::scene::{LightsMode, Scene};
use ash::vk;
use std::sync::atomic::{AtomicU64, Ordering};

/// A scene prepared for environments of one shape on the GPU: its plan and every resource
/// its passes write, made once and reused by every frame.
pub struct Resident {
    scene: Scene,
    plan: Plan,
    shape: MapShape,
    lit: Lit,
    inputs: Inputs,
    gbuf: GBuffer,
    frame: GpuEnvMap,
    cache: FrameCache,
    /// The environment as the passes read it: the caller's, its non-radiance texels zeroed.
    clean: GpuEnvMap,
    sanitizer: Sanitizer,
    zeroed: Buffer,
    /// The diffuse lights, extracted on the GPU every frame, where the scene extracts them.
    diffuse: Option<DiffuseLights>,
    /// The chain's lights, extracted on the GPU every frame, where the scene extracts them.
    chain: Option<ChainLights>,
    /// The extraction pass and the maps' means the extractions read, where there are any.
    means: Option<Means>,
    /// The split-sum chain's rough levels dealt into time slices (one: no slicing).
    slices: Vec<Vec<LevelLayers>>,
    /// Frames recorded since the last whole refilter.
    frames: AtomicU64,
    /// The paraboloid's conversion, planned once where it takes areas and its plan is small
    /// enough (`Converter::plan_pays`).
    dp_plan: Option<ConvertPlan>,
}

impl Resident {
    /// The shaded frame (linear RGB, the camera's size), written by each recorded frame; a
    /// caller reads it in its own passes or downloads it.
    pub fn frame(&self) -> &GpuEnvMap {
        &self.frame
    }

    /// The plan every frame follows.
    pub fn plan(&self) -> &Plan {
        &self.plan
    }

    /// The paraboloid's conversion plan, where every frame converts it from one (a lat-long
    /// map whose plan is small enough: `Converter::plan_pays`).
    pub fn conversion_plan(&self) -> Option<&ConvertPlan> {
        self.dp_plan.as_ref()
    }

    /// The shape of the environments it renders from.
    pub fn shape(&self) -> MapShape {
        self.shape
    }

    /// How many texels of the last recorded frame's environment were not a finite,
    /// non-negative radiance and were read as zero: one u32 on the GPU (STORAGE, TRANSFER_SRC),
    /// for the caller to copy or read in its own passes.
    pub fn zeroed_texels(&self) -> &Buffer {
        &self.zeroed
    }

    /// Spreads the split-sum chain's rough levels over `slices` frames (Unity's time
    /// slicing; 1, the default, refilters every level every frame): the next frame recorded
    /// refilters every level, each after it level 0 (the mirror) and one slice of the rest
    /// in turn ([`time_slices`]: each (level, layer) in one slice, the slices of about equal
    /// cost), so a level lags its map by at most `slices` − 1 frames. Everything else (SH,
    /// the FIS paraboloid, prefiltered maps) follows the map every frame. Frames are counted
    /// when recorded: a recording dropped unsubmitted skips its slice for a round (call
    /// [`Resident::refilter_all`] to start afresh). Refused for 0 or a scene without
    /// split-sum.
    pub fn set_time_slices(&mut self, slices: u32) -> Result<()> {
        let Some(split) = &self.plan.split else {
            return Err(Error::Invalid(
                "time slicing spreads the split-sum chain over frames, and this scene has no \
                 split-sum object"
                    .into(),
            ));
        };
        if slices == 0 {
            return Err(Error::Invalid("time slicing over 0 frames".into()));
        }
        let ss = &self.scene.split_sum;
        let samples = LevelSamples {
            base: ss.samples,
            rough_boost: ss.rough_boost,
        };
        let layers = Mapping::DualParaboloid.layers();
        self.slices = time_slices(split.size, layers, ss.levels, samples, slices);
        self.refilter_all();
        Ok(())
    }

    /// The frames the split-sum chain's refilter is spread over ([`Resident::set_time_slices`]).
    pub fn time_slices(&self) -> u32 {
        self.slices.len().max(1) as u32
    }

    /// Makes the next frame recorded refilter every level (after a cut, where the old map's
    /// levels should not linger); later frames go on slice by slice.
    pub fn refilter_all(&self) {
        self.frames.store(0, Ordering::Relaxed);
    }

    /// The split-sum units the next frame refilters (`None`: all), counting it recorded.
    fn next_split(&self) -> Option<Vec<LevelLayers>> {
        let f = self.frames.fetch_add(1, Ordering::Relaxed);
        if self.slices.len() <= 1 || f == 0 {
            return None;
        }
        let slice = &self.slices[((f - 1) % self.slices.len() as u64) as usize];
        let mirror = LevelLayers {
            level: 0,
            layers: 0..Mapping::DualParaboloid.layers(),
        };
        Some(
            std::iter::once(mirror)
                .chain(slice.iter().cloned())
                .collect(),
        )
    }
}

/// Why `scene` cannot render from a GPU image, if it cannot: Monte Carlo builds its sampling
/// tables on the host.
fn refusal(plan: &Plan) -> Option<String> {
    if let Some(k) = plan
        .objects
        .iter()
        .position(|o| matches!(o.technique, crate::scene::Technique::Mc { .. }))
    {
        return Some(format!(
            "object {k} is shaded by Monte Carlo, whose sampling tables are built on the host: \
             the resident path cannot render it"
        ));
    }
    None
}

impl Renderer {
    /// Prepares `scene` for rendering from environments of shape `env` that live on the GPU:
    /// plans it, builds its pipelines and makes every resource its passes write. Refuses a
    /// scene with Monte Carlo objects (their sampling tables need the map on the host).
    pub fn resident(&self, scene: &Scene, env: MapShape) -> Result<Resident> {
        scene.validate().map_err(Error::Invalid)?;
        let plan = plan_for(scene, env);
        if let Some(why) = refusal(&plan) {
            return Err(Error::Invalid(why));
        }
        let ctx = &self.ctx;
        let shade = self.shade_pass()?;
        shade.prepare_code(&plan.code)?;
        if let Some(opts) = &plan.dp {
            self.converter()?
                .prepare_for((env.mapping, env.width, env.height), opts)?;
        }
        let passes = self.passes(&plan)?;
        let mut lit = Lit::none(&plan);
        let extract = scene.environment.lights == LightsMode::Extract;
        let diffuse = match &plan.lights.diffuse {
            Some(opts) if extract => {
                let d = DiffuseLights::new(ctx, &plan, env, opts.ratio)?;
                lit.sh = plan.lights.sh;
                lit.prefiltered = plan.lights.prefiltered;
                lit.sh_residual_at = d
                    .sh_residual
                    .is_some()
                    .then(|| crate::math::sh::count(plan.lmax) as u32);
                Some(d)
            }
            _ => None,
        };
        let chain = match &plan.lights.chain {
            Some(opts) if extract => ChainLights::new(ctx, scene, &plan, env, opts, &mut lit)?,
            _ => None,
        };
        let cells = diffuse.as_ref().map_or(0, |_| CLUSTER_CELLS);
        lit.gpu = match &chain {
            Some(c) => Some(GpuLights::on_gpu(ctx, c.extraction.max(), c.nodes, cells)?),
            None if diffuse.is_some() => Some(GpuLights::clusters_on_gpu(ctx, cells)?),
            None => None,
        };
        let means = (diffuse.is_some() || chain.is_some())
            .then(|| Means::new(ctx))
            .transpose()?;
        let job = Job {
            ctx,
            scene,
            plan: &plan,
            orientation: scene.environment.orientation(),
        };
        let sh = inputs::sh_layout(&job, &lit);
        let inputs = Inputs::new(&job, &lit, &sh)?;
        // What no environment changes (SH-BRDF and DFG tables) is computed now, once, not in
        // every frame.
        if !plan.tables.is_empty() || plan.split.is_some() {
            let mut marks = Marks(Vec::new());
            ctx.run_untimed("resident: tables", |rec| {
                inputs::record_tables(rec, &mut marks, &job, &passes, &inputs)
            })?;
        }
        let levels = inputs.split.as_ref().map(|(chain, _)| chain.mips());
        let at = (&inputs.pre_offsets[..], &sh.offsets[..]);
        let objects = gpu_objects(scene, &plan, &lit, at, levels);
        let camera = &scene.camera;
        let mut gbuf = GBuffer::new(ctx, camera.width, camera.height, &objects)?;
        gbuf.camera = Some(*camera);
        let frame = target(ctx, "resident frame", camera.width, camera.height)?;
        let clean = GpuEnvMap::new(
            ctx,
            "resident environment",
            env.mapping,
            env.width,
            env.height,
        )?;
        let dp_plan = match &plan.dp {
            Some(opts) => {
                let (conv, shape) = (self.converter()?, (env.mapping, env.width, env.height));
                let opts = inputs::dp_convert_options(opts, &lit);
                match conv.plan_pays(shape, &opts) {
                    true => Some(conv.plan(shape, &opts)?),
                    false => None,
                }
            }
            None => None,
        };
        let zeroed = Buffer::new(
            ctx,
            "resident zeroed texels",
            Sanitizer::COUNT_BYTES,
            vk::BufferUsageFlags::STORAGE_BUFFER
                | vk::BufferUsageFlags::TRANSFER_DST
                | vk::BufferUsageFlags::TRANSFER_SRC,
            gpu_allocator::MemoryLocation::GpuOnly,
        )?;
        Ok(Resident {
            scene: scene.clone(),
            plan,
            shape: env,
            lit,
            inputs,
            gbuf,
            frame,
            cache: FrameCache::new(),
            clean,
            sanitizer: Sanitizer::new(ctx)?,
            zeroed,
            diffuse,
            chain,
            means,
            slices: Vec::new(),
            frames: AtomicU64::new(0),
            dp_plan,
        })
    }

    /// Records one frame of `r` from `env` into `rec` (the caller's command buffer): every
    /// pass before the shading, the G-buffer and the shading into [`Resident::frame`]. Reads
    /// nothing back and submits nothing; descriptor sets and transient buffers come from `r`'s
    /// cache, so a frame on the same images allocates nothing (record with timestamps off for
    /// that: their query pools are per recording). `env` must have `r`'s shape and SAMPLED
    /// usage.
    pub fn record_resident(&self, rec: &mut Recorder, r: &Resident, env: &GpuEnvMap) -> Result<()> {
        self.record_frame(rec, r, env, &mut Marks(Vec::new()))
    }

    /// Renders one frame of `r` from `env` (already on the GPU) in a submission of its own,
    /// timed, and reads the frame back: `envlight render --resident`, to compare the
    /// resident path with the host one on any scene it can render.
    pub fn render_resident(&self, r: &Resident, env: &GpuEnvMap) -> Result<Rendered> {
        let mut marks = Marks(Vec::new());
        let Timed {
            value: readback,
            timings: t,
        } = self.ctx.run("rendering (resident)", |rec| {
            self.record_frame(rec, r, env, &mut marks)?;
            r.frame.record_download(rec, 0)
        })?;
        let mut records = Vec::new();
        marks.split(&t, &mut records);
        Ok(Rendered {
            frame: shading::frame_of(&readback, &r.gbuf)?,
            records,
            plan: r.plan.clone(),
            mc: None,
            lights_ms: None,
        })
    }

    /// [`Renderer::record_resident`], each pass's spans marked in `marks`.
    fn record_frame(
        &self,
        rec: &mut Recorder,
        r: &Resident,
        env: &GpuEnvMap,
        marks: &mut Marks,
    ) -> Result<()> {
        let s = r.shape;
        if (env.mapping, env.width, env.height) != (s.mapping, s.width, s.height) {
            return Err(Error::Invalid(format!(
                "image '{}': a {} {}x{} map, but this resident render was prepared for a {} \
                 {}x{} one",
                env.image.name(),
                env.mapping.name(),
                env.width,
                env.height,
                s.mapping.name(),
                s.width,
                s.height
            )));
        }
        if !env
            .image
            .desc()
            .usage
            .contains(vk::ImageUsageFlags::SAMPLED)
        {
            return Err(Error::Invalid(format!(
                "image '{}' lacks SAMPLED usage, which every pass reading the environment needs",
                env.image.name()
            )));
        }
        let job = Job {
            ctx: &self.ctx,
            scene: &r.scene,
            plan: &r.plan,
            orientation: r.scene.environment.orientation(),
        };
        let passes = self.passes(&r.plan)?;
        let shade = self.shade_pass()?;
        let previous = rec.swap_frame_cache(Some(r.cache.clone()));
        let ins = (&r.inputs, &r.lit, &r.gbuf);
        let recorded = (|| {
            // What the engine's frame holds that is no radiance (NaN, ∞, negative) is read as
            // zero by every pass, and counted.
            r.sanitizer.record(rec, env, &r.clean, &r.zeroed)?;
            let env = &r.clean;
            // The frame's SH projection, where the lights read its band 0.
            let sh = match (&r.means, passes.sh, &r.inputs.sh_out) {
                (Some(_), Some((p, _)), Some(out)) => Some((p, out)),
                _ => None,
            };
            if let (Some(means), Some(lights)) = (&r.means, &r.lit.gpu) {
                marks.record(rec, PassKind::Lights, |rec| {
                    let mean = means.record(rec, &job, env, sh)?;
                    let ex = &means.extractor;
                    if let Some(d) = &r.diffuse {
                        d.record(rec, ex, &job, env, lights, mean, sh)?;
                    }
                    match &r.chain {
                        Some(c) => c.record(rec, ex, &job, env, lights, mean),
                        None => Ok(()),
                    }
                })?;
            }
            let work = Work {
                tables: false,
                split: r.next_split(),
                diffuse_residual: r.diffuse.as_ref().map(|d| d.extraction.residual()),
                chain_residual: r.chain.as_ref().map(|c| c.extraction.residual()),
                dp_plan: r.dp_plan.as_ref(),
                sh_projected: sh.is_some(),
            };
            inputs::record(rec, marks, &job, &passes, ins, env, &work, || Ok(()))?;
            let with = Shading {
                mc: None,
                sh_rotation: self.sh_rotation,
            };
            let draw = shading::draw(&job, ins, env, with)?;
            shading::record_draw(rec, marks, shade, &r.gbuf, &draw, &r.frame)
        })();
        rec.swap_frame_cache(previous);
        recorded
    }
}

/// Cells of the diffuse lights' clusters (`CLUSTER_GRID` × `CLUSTER_GRID`/2).
const CLUSTER_CELLS: u32 = CLUSTER_GRID * (CLUSTER_GRID / 2);

/// Most light texels the resident path's diffuse extraction keeps (the host's is uncapped):
/// its records and sort take 56 bytes each. A map with more texels above the ratio keeps the
/// brightest; the rest stay in the residual, counted.
pub const DIFFUSE_GPU_MAX: u32 = 1 << 20;

/// The resident path's diffuse lights: each frame the map's band 0 (its mean), the
/// extraction by the scene's diffuse ratio, its records gathered into clusters the shade pass
/// adds to SH and prefiltered irradiance objects, and the residual projected to SH, which
/// those objects shade with instead of the map's (the host path subtracts the light texels'
/// coefficients instead: the same sum).
struct DiffuseLights {
    extraction: GpuExtraction,
    /// The residual's projection, copied after the map's in the SH output (where SH objects
    /// add the lights).
    sh_residual: Option<Buffer>,
    ratio: f64,
}

impl DiffuseLights {
    fn new(ctx: &crate::gpu::Context, plan: &Plan, env: MapShape, ratio: f64) -> Result<Self> {
        let layers = env.mapping.layers();
        let texels = (env.width as u64 * env.height as u64 * layers as u64)
            .min(DIFFUSE_GPU_MAX as u64) as u32;
        let usage = vk::BufferUsageFlags::STORAGE_BUFFER
            | vk::BufferUsageFlags::TRANSFER_DST
            | vk::BufferUsageFlags::TRANSFER_SRC;
        let buffer = |name, lmax| {
            Buffer::new(
                ctx,
                name,
                ShProjector::output_bytes(lmax),
                usage,
                gpu_allocator::MemoryLocation::GpuOnly,
            )
        };
        Ok(DiffuseLights {
            extraction: GpuExtraction::new(ctx, env.mapping, env.width, env.height, texels)?,
            sh_residual: match plan.lights.sh {
                true => Some(buffer("resident residual sh", plan.lmax)?),
                false => None,
            },
            ratio,
        })
    }

    /// Records the frame's extraction from `env` by its mean luminance (`mean`'s band 0),
    /// its clusters into `lights` and, with `sh` (the frame's projector and SH output, where
    /// the plan projects), the residual's projection into the output's second half.
    #[allow(clippy::too_many_arguments)]
    fn record(
        &self,
        rec: &mut Recorder,
        extractor: &Extractor,
        job: &Job<'_>,
        env: &GpuEnvMap,
        lights: &GpuLights,
        mean: &Buffer,
        sh: Option<(&ShProjector, &Buffer)>,
    ) -> Result<()> {
        let orientation = &job.orientation;
        let file_to_world = orientation.checked_world_to_file()?.transpose();
        let lmax = job.plan.lmax;
        extractor.record(rec, env, mean, self.ratio, &self.extraction)?;
        let at = lights.cluster_at();
        extractor.record_clusters(
            rec,
            &self.extraction,
            file_to_world,
            CLUSTER_GRID,
            lights.buffer(),
            at,
        )?;
        if let (Some(res), Some((p, out))) = (&self.sh_residual, sh) {
            let residual = self.extraction.residual();
            p.record_into(rec, residual, lmax, orientation, res)?;
            let bytes = ShProjector::output_bytes(lmax);
            rec.copy_buffer_regions(res, out, &[(0, bytes, bytes)]);
        }
        Ok(())
    }
}

/// What the diffuse and chain extractions share: the extraction pass, and the maps' mean
/// luminance they read, band 0 of the frame's own SH projection where the plan projects
/// (`inputs::record` then only packs it), else a band-0 projection of its own.
struct Means {
    extractor: Extractor,
    projector: ShProjector,
    l00: Buffer,
}

impl Means {
    fn new(ctx: &crate::gpu::Context) -> Result<Means> {
        Ok(Means {
            extractor: Extractor::new(ctx)?,
            projector: ShProjector::new(ctx, Subgroups::Auto)?,
            l00: Buffer::new(
                ctx,
                "resident L00",
                ShProjector::output_bytes(0),
                vk::BufferUsageFlags::STORAGE_BUFFER | vk::BufferUsageFlags::TRANSFER_DST,
                gpu_allocator::MemoryLocation::GpuOnly,
            )?,
        })
    }

    /// Records the projection `env`'s mean is read from, into `sh`'s output where given (the
    /// frame's projection, at the plan's order) or its own band 0; returns where it is.
    fn record<'a>(
        &'a self,
        rec: &mut Recorder,
        job: &Job<'_>,
        env: &GpuEnvMap,
        sh: Option<(&ShProjector, &'a Buffer)>,
    ) -> Result<&'a Buffer> {
        let orientation = &job.orientation;
        match sh {
            Some((p, out)) => {
                p.record_into(rec, env, job.plan.lmax, orientation, out)?;
                Ok(out)
            }
            None => {
                self.projector
                    .record_into(rec, env, 0, orientation, &self.l00)?;
                Ok(&self.l00)
            }
        }
    }
}

/// Most light texels the resident path's chain extraction keeps where the scene sets no
/// `light_texels`: the host path's default (`crate::abi::lights::CHAIN_MAX_TEXELS`). A map
/// with more texels above the ratio keeps the brightest; the rest stay in the residual,
/// counted.
pub const CHAIN_GPU_MAX: u32 = crate::abi::lights::CHAIN_MAX_TEXELS;

/// The resident path's chain lights: each frame the extraction by the scene's ratio (the
/// residual filled from around the lights grown by the scene's `light_fill` rings, or
/// clamped at the threshold, as the host's), its records sorted by a spatial key, prepared
/// for the shade pass's walk and built into a light tree (`Extractor::record_prepare`), and
/// the residual,
/// which the paraboloid converts and prefiltered Phong maps filter where the lights are added
/// per pixel. What the host path decides from the texels found (whether their quadratures
/// resolve each lobe, and how fine they are) is decided here from the map's largest texel,
/// since no frame is read back.
struct ChainLights {
    extraction: GpuExtraction,
    /// Quadrature nodes per light texel.
    nodes: u32,
    ratio: f64,
}

impl ChainLights {
    /// The chain lights of `scene` for maps of shape `env`, with `lit`'s chain flags set
    /// (whether the paraboloid holds the residual, which Phong objects add the texels), or
    /// `None` where no technique would add them.
    fn new(
        ctx: &crate::gpu::Context,
        scene: &Scene,
        plan: &Plan,
        env: MapShape,
        opts: &crate::math::lights::ExtractOptions,
        lit: &mut Lit,
    ) -> Result<Option<ChainLights>> {
        let rho = largest_rho(env.mapping, env.width, env.height);
        let lp = &plan.lights;
        lit.dp = lp.dp && resolves_rho(rho, lp.finest_chain);
        lit.phong = plan
            .objects
            .iter()
            .map(|o| o.phong_prefiltered() && o.lobe.is_some_and(|s| resolves_rho(rho, s)))
            .collect();
        if !lit.dp && !lit.phong.contains(&true) {
            return Ok(None);
        }
        let finest = plan
            .objects
            .iter()
            .zip(&lit.phong)
            .filter(|&(o, &lit_phong)| lit_phong || (lit.dp && o.on_chain))
            .filter_map(|(o, _)| o.lobe)
            .fold(1.0, f64::min);
        let cells = cells_for_rho(rho, finest);
        // No more room than the map has texels (a small map's buffers stay small).
        let texels = env.width as u64 * env.height as u64 * env.mapping.layers() as u64;
        let room = (scene.environment.light_texels.unwrap_or(CHAIN_GPU_MAX) as u64)
            .min(texels)
            .max(1) as u32;
        Ok(Some(ChainLights {
            extraction: GpuExtraction::with_fill(
                ctx,
                env.mapping,
                env.width,
                env.height,
                room,
                opts.fill,
            )?,
            nodes: 4 * cells * cells,
            ratio: opts.ratio,
        }))
    }

    /// Records the frame's extraction from `env` by its mean luminance (`mean`'s band 0) and
    /// the preparation of its texels into `lights`.
    fn record(
        &self,
        rec: &mut Recorder,
        extractor: &Extractor,
        job: &Job<'_>,
        env: &GpuEnvMap,
        lights: &GpuLights,
        mean: &Buffer,
    ) -> Result<()> {
        let file_to_world = job.orientation.checked_world_to_file()?.transpose();
        extractor.record(rec, env, mean, self.ratio, &self.extraction)?;
        extractor.record_prepare(rec, &self.extraction, file_to_world, lights)
    }
}
