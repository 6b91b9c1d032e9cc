//! Rendering a [`Scene`]: [`plan()`] resolves what the scene asks of the GPU once; the stages
//! then run it in order (lights, the inputs' resources, Monte Carlo where asked, shading: one
//! submission without Monte Carlo) and record what each pass cost.

mod inputs;
mod lights;
pub mod plan;
mod records;
mod resident;
pub mod score;
mod shading;

pub use crate::scene::MapShape;
pub use plan::{
    plan, plan_for, split_size, LightsPlan, ObjectPlan, PassKind, Plan, PlannedPass, SplitPlan,
    TablePlan,
};
pub use resident::{Resident, CHAIN_GPU_MAX, DIFFUSE_GPU_MAX};

use crate::error::{Error, Result};
use crate::gpu::{total_ms, Context, Timed, Timing};
use crate::math::envmap::EnvMap;
use crate::math::Orientation;
use crate::passes::gbuffer::GBuffer;
use crate::passes::sh_project::Subgroups;
use crate::passes::shade::Rotation;
use crate::passes::{
    BruteFilter, Converter, GBufferPass, GpuEnvMap, MipChain, MonteCarlo, ShBrdfProjector,
    ShPacker, ShProjector, Shade, SplitSum,
};
use crate::scene::Scene;
use inputs::{Inputs, Passes, Work};
use records::{gpu_objects, Marks};
use shading::Shading;
use std::cell::OnceCell;

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
        total_ms(&self.timings)
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

/// Renders scenes: holds each pass, built the first time a scene needs it and reused by
/// every later render on the same context.
pub struct Renderer {
    ctx: Context,
    converter: OnceCell<Converter>,
    mip: OnceCell<MipChain>,
    sh: OnceCell<ShProjector>,
    sh_pack: OnceCell<ShPacker>,
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

impl Renderer {
    /// A renderer on `ctx` (no pass is built yet).
    pub fn new(ctx: &Context) -> Renderer {
        Renderer {
            ctx: ctx.clone(),
            converter: OnceCell::new(),
            mip: OnceCell::new(),
            sh: OnceCell::new(),
            sh_pack: OnceCell::new(),
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

    /// The context it renders on.
    pub fn context(&self) -> &Context {
        &self.ctx
    }

    /// Whether passes built from now on may use subgroup operations (the default: where the
    /// device has them); [`Subgroups::Off`] tests the fallbacks. Passes already built keep
    /// theirs.
    pub fn set_subgroups(&mut self, subgroups: Subgroups) {
        self.subgroups = subgroups;
    }

    /// Shades every scene with the whole shade shader, where a scene of one technique would
    /// take the variant built for it (`crate::passes::shade::module`); for tests, which
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

    /// The shade pass, built on first use.
    fn shade_pass(&self) -> Result<&Shade> {
        pass(&self.shade, || {
            let mut s = Shade::with_subgroups(&self.ctx, self.subgroups)?;
            if self.whole_shade {
                s.whole_shader_only();
            }
            Ok(s)
        })
    }

    /// Renders `scene` with `env` (from [`Scene::load_environment`]). Without Monte Carlo the
    /// render is one submission: the uploads, every pass before the shading (SH coefficients stay on
    /// the GPU, packed there for each object), the draw and the frame's download. Monte Carlo
    /// submits in turn the inputs, its batches (an error target reads the estimate back between
    /// them; a map that is not lat-long comes back converted for its sampling tables) and the
    /// shading.
    pub fn render(&self, scene: &Scene, env: &EnvMap) -> Result<Rendered> {
        scene.validate().map_err(Error::Invalid)?;
        let plan = plan(scene, env);
        let shade = self.shade_pass()?;
        // The shade pipeline is the longest build: it builds on a second thread while this
        // one builds the other passes, extracts the lights and records and runs everything
        // before the shading. So do the dual paraboloid's conversion pipelines, on a third.
        let converter = match plan.dp {
            Some(_) => Some(self.converter()?),
            None => None,
        };
        std::thread::scope(|s| {
            let shade_build = s.spawn(|| shade.prepare_code(&plan.code));
            let convert_build = s.spawn(|| match (converter, &plan.dp) {
                // The pipelines that serve the whole map serve its halves too.
                (Some(conv), Some(opts)) => {
                    conv.prepare_for((env.mapping, env.width, env.height), opts)
                }
                _ => Ok(()),
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
            let job = Job {
                ctx: &self.ctx,
                scene,
                plan: &plan,
                orientation: scene.environment.orientation(),
            };
            self.render_planned(&job, env, shade, builds)
        })
    }

    /// The passes `plan` runs, built on first use.
    fn passes(&self, plan: &Plan) -> Result<Passes<'_>> {
        let ctx = &self.ctx;
        let runs = |k| plan.runs(k);
        Ok(Passes {
            sh: match runs(PassKind::ShProjection) {
                true => Some((
                    pass(&self.sh, || ShProjector::new(ctx, self.subgroups))?,
                    pass(&self.sh_pack, || ShPacker::new(ctx))?,
                )),
                false => None,
            },
            dp: match runs(PassKind::DualParaboloid) {
                true => Some((self.converter()?, pass(&self.mip, || MipChain::new(ctx))?)),
                false => None,
            },
            brute: match runs(PassKind::Prefilter) {
                true => Some(pass(&self.brute, || BruteFilter::new(ctx))?),
                false => None,
            },
            gbuffer: pass(&self.gbuffer, || GBufferPass::new(ctx))?,
            sh_brdf: match runs(PassKind::ShBrdfTable) {
                true => Some(pass(&self.sh_brdf, || Ok(ShBrdfProjector::new(ctx)))?),
                false => None,
            },
            split: match runs(PassKind::SplitSum) {
                true => Some(pass(&self.split, || SplitSum::new(ctx))?),
                false => None,
            },
        })
    }

    /// [`Renderer::render`] once the shade pipeline, and the conversion to the dual
    /// paraboloid where there is one, are being built: the plan's stages in order.
    fn render_planned(
        &self,
        job: &Job<'_>,
        env: &EnvMap,
        shade: &Shade,
        builds: Builds<'_>,
    ) -> Result<Rendered> {
        // Pipeline creation first: it is not GPU work.
        let passes = self.passes(job.plan)?;
        let lit = lights::extract(job.ctx, job.plan, env, &job.orientation)?;
        let env_gpu = GpuEnvMap::new(job.ctx, "environment", env.mapping, env.width, env.height)?;
        let sh = inputs::sh_layout(job, &lit);
        let inputs = Inputs::new(job, &lit, &sh)?;
        let levels = inputs.split.as_ref().map(|(chain, _)| chain.mips());
        let at = (&inputs.pre_offsets[..], &sh.offsets[..]);
        let objects = gpu_objects(job.scene, job.plan, &lit, at, levels);
        let camera = &job.scene.camera;
        let mut gbuf = GBuffer::new(job.ctx, camera.width, camera.height, &objects)?;
        gbuf.camera = Some(*camera);

        let mut records = Vec::new();
        let mut marks = Marks(Vec::new());
        let ins = (&inputs, &lit, &gbuf);
        if job.plan.mc.is_none() {
            // One submission: everything before the shading, the draw and the download.
            let with = Shading {
                mc: None,
                sh_rotation: self.sh_rotation,
            };
            let draw = shading::draw(job, ins, &env_gpu, with)?;
            let frame = shading::frame_target(job, &gbuf)?;
            let Builds {
                shade: built,
                convert,
            } = builds;
            let Timed {
                value: readback,
                timings: t,
            } = job.ctx.run("rendering", |rec| {
                env_gpu.record_upload(rec, env)?;
                inputs::record(
                    rec,
                    &mut marks,
                    job,
                    &passes,
                    ins,
                    &env_gpu,
                    &Work::ALL,
                    convert,
                )?;
                built()?;
                shading::record_draw(rec, &mut marks, shade, &gbuf, &draw, &frame)?;
                frame.record_download(rec, 0)
            })?;
            marks.split(&t, &mut records);
            let frame = shading::frame_of(&readback, &gbuf)?;
            return Ok(self.rendered(job, &inputs, frame, records, None, &lit));
        }
        let t = job
            .ctx
            .run("rendering: inputs", |rec| {
                env_gpu.record_upload(rec, env)?;
                inputs::record(
                    rec,
                    &mut marks,
                    job,
                    &passes,
                    ins,
                    &env_gpu,
                    &Work::ALL,
                    builds.convert,
                )
            })?
            .timings;
        marks.split(&t, &mut records);
        // Monte Carlo reads the host between its batches (an error target, a sampling table).
        let mc_pass = pass(&self.mc, || MonteCarlo::new(job.ctx))?;
        let with = (self.converter()?, mc_pass);
        let mc = shading::monte_carlo(job, with, (env, &env_gpu), &gbuf, &mut records)?;
        let with = Shading {
            mc: mc.as_ref(),
            sh_rotation: self.sh_rotation,
        };
        let frame = shading::shade(job, shade, ins, &env_gpu, with, builds.shade, &mut records)?;
        let mc = mc.map(|m| (m.samples, m.error));
        Ok(self.rendered(job, &inputs, frame, records, mc, &lit))
    }

    /// What a render produced, the notes of its SH-BRDF objects' lighting added (from the
    /// coefficients' host copy, read once the frame is done).
    fn rendered(
        &self,
        job: &Job<'_>,
        inputs: &Inputs,
        frame: crate::math::envmap::EnvMap,
        records: Vec<PassRecord>,
        mc: Option<(u32, Option<f64>)>,
        lit: &lights::Lit,
    ) -> Rendered {
        let mut plan = job.plan.clone();
        if let Some(host) = &inputs.sh_host {
            let flat: Vec<f32> = host.read(crate::math::sh::count(job.plan.lmax) * 3);
            let c = crate::passes::ShCoefficients::from_f32(job.plan.lmax, &flat).coeffs;
            plan.notes.extend(shading::ringing_notes(job, &c));
        }
        Rendered {
            frame,
            records,
            plan,
            mc,
            lights_ms: lit.ms,
        }
    }
}

/// What every stage of one render reads.
pub(crate) struct Job<'a> {
    ctx: &'a Context,
    scene: &'a Scene,
    plan: &'a Plan,
    /// The environment's orientation (world to file).
    orientation: Orientation,
}

/// The pipeline builds a render starts on other threads; each call waits for its build.
struct Builds<'a> {
    shade: Box<dyn FnOnce() -> Result<()> + 'a>,
    convert: Box<dyn FnOnce() -> Result<()> + 'a>,
}

/// Renders `scene` with `env` (from [`Scene::load_environment`]) on `ctx`, with a renderer of
/// its own (see [`Renderer`] to reuse the passes across renders).
pub fn render(ctx: &Context, scene: &Scene, env: &EnvMap) -> Result<Rendered> {
    Renderer::new(ctx).render(scene, env)
}
