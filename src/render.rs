//! Rendering a [`Scene`]: runs exactly the passes its [`plan`] lists, and records what each
//! cost.

use crate::error::{Error, Result};
use crate::gpu::layout::brdf::technique;
use crate::gpu::{Buffer, Context, GpuEnvMap, Timing};
use crate::math::brdf::Brdf;
use crate::math::filter::Kernel;
use crate::math::{sh, Mapping, Orientation};
use crate::passes::filter::{BruteFilter, FilterTarget};
use crate::passes::gbuffer::{shape_record, GBufferPass, GpuObject};
use crate::passes::mc::{McEnv, McOptions, MonteCarlo};
use crate::passes::mip::MipChain;
use crate::passes::sh_project::{ShProjector, Subgroups};
use crate::passes::shade::{Shade, ShadeInputs};
use crate::passes::{ConvertOptions, Converter};
use crate::scene::{plan, PassKind, Plan, Scene, SceneObject, Technique, DEFAULT_FIS_BIAS};
use crate::EnvMap;
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

/// Side of the dual paraboloid for `map`: about as many texels in the two discs as the map
/// has on the sphere, as a power of two from 16 to 1024.
pub fn default_dp_size(map: &EnvMap) -> u32 {
    let n = (map.width as f64) * (map.height as f64) * map.layers() as f64;
    let side = (2.0 * n / std::f64::consts::PI).sqrt();
    (side.max(1.0) as u32).next_power_of_two().clamp(16, 1024)
}

/// The GPU record of a scene object; `data_offset` locates its SH coefficients or its
/// prefiltered map (0 for other techniques).
pub fn object_record(o: &SceneObject, data_offset: u32) -> GpuObject {
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
    };
    g.albedo = [a[0] as f32, a[1] as f32, a[2] as f32, tech as f32];
    g.brdf = [brdf.id() as f32, p[0] as f32, p[1] as f32, samples as f32];
    g.extra = extra;
    g
}

/// Renders `scene` with `env` (from [`load_environment`]) on `ctx`.
pub fn render(ctx: &Context, scene: &Scene, env: &EnvMap) -> Result<Rendered> {
    scene.validate().map_err(Error::Invalid)?;
    let plan = plan(scene, env.mapping);
    let kinds = plan.kinds();
    let needs = |k: PassKind| kinds.contains(&k);
    let orientation: Orientation = scene.environment.orientation();
    let mut records = Vec::new();
    let env_gpu = GpuEnvMap::upload(ctx, env)?;
    // Building a converter makes no pipeline: each is made on its first run.
    let converter = if needs(PassKind::DualParaboloid) || needs(PassKind::MonteCarlo) {
        Some(Converter::new(ctx)?)
    } else {
        None
    };

    // SH: one projection at the highest order asked; each object gets its own truncation.
    let mut sh_coeffs: Vec<[f64; 3]> = Vec::new();
    let mut sh_offsets = vec![0u32; scene.objects.len()];
    if needs(PassKind::ShProjection) {
        let lmax = scene
            .objects
            .iter()
            .filter_map(|o| match o.material.technique() {
                Technique::Sh { order } => Some(order),
                _ => None,
            })
            .max()
            .unwrap_or(2);
        let (c, t) =
            ShProjector::new(ctx, Subgroups::Auto)?.run_oriented(&env_gpu, lmax, &orientation)?;
        records.push(PassRecord {
            kind: PassKind::ShProjection,
            timings: t,
        });
        for (k, o) in scene.objects.iter().enumerate() {
            if let Technique::Sh { order } = o.material.technique() {
                sh_offsets[k] = sh_coeffs.len() as u32;
                sh_coeffs.extend(sh::irradiance_coeffs(&c.coeffs[..sh::count(order)]));
            }
        }
    }

    // FIS: the dual paraboloid and its MIP chain.
    let mut dp = None;
    if needs(PassKind::DualParaboloid) {
        let size = scene.fis.size.unwrap_or_else(|| default_dp_size(env));
        let conv = converter
            .as_ref()
            .unwrap_or_else(|| unreachable!("made above"));
        let (map, t) = conv.run_mipped(
            &env_gpu,
            &ConvertOptions {
                to: Mapping::DualParaboloid,
                size,
                orientation,
                supersample: None,
            },
        )?;
        records.push(PassRecord {
            kind: PassKind::DualParaboloid,
            timings: t,
        });
        let t = MipChain::new(ctx)?.run(&map)?;
        records.push(PassRecord {
            kind: PassKind::MipChain,
            timings: t,
        });
        dp = Some(map);
    }

    // Prefiltered maps, one per distinct (kernel, size), concatenated into one buffer.
    let mut pre_offsets = vec![0u32; scene.objects.len()];
    let mut pre_buffer = None;
    if needs(PassKind::Prefilter) {
        let brute = BruteFilter::new(ctx)?;
        let mut texels: Vec<[f32; 4]> = Vec::new();
        let mut made: Vec<(u64, u32, u32)> = Vec::new();
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
            if let Some(&(_, _, off)) = made.iter().find(|m| m.0 == key && m.1 == size) {
                pre_offsets[k] = off;
                continue;
            }
            let (map, t) = brute.run(
                &env_gpu,
                &orientation,
                kernel,
                FilterTarget {
                    to: Mapping::LatLong,
                    size,
                },
            )?;
            records.push(PassRecord {
                kind: PassKind::Prefilter,
                timings: t,
            });
            let off = texels.len() as u32;
            texels.extend(
                map.download(ctx)?
                    .texels
                    .iter()
                    .map(|t| [t[0], t[1], t[2], 0.0]),
            );
            made.push((key, size, off));
            pre_offsets[k] = off;
        }
        pre_buffer = Some(Buffer::storage(ctx, "prefiltered maps", &texels)?);
    }

    // The objects' GPU records.
    let objects: Vec<GpuObject> = scene
        .objects
        .iter()
        .enumerate()
        .map(|(k, o)| object_record(o, sh_offsets[k].max(pre_offsets[k])))
        .collect();
    let (gbuf, t) = GBufferPass::new(ctx)?.run(&scene.camera, &objects)?;
    records.push(PassRecord {
        kind: PassKind::GBuffer,
        timings: t,
    });

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
        let conv = converter
            .as_ref()
            .unwrap_or_else(|| unreachable!("made above"));
        let (mc_env, t) = McEnv::for_map(ctx, conv, env, &env_gpu, &orientation)?;
        if !t.is_empty() {
            records.push(PassRecord {
                kind: PassKind::LatLong,
                timings: t,
            });
        }
        let (res, t) = MonteCarlo::new(ctx)?.run(
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

    let (frame, t) = Shade::new(ctx)?.run(
        &gbuf,
        &ShadeInputs {
            env: &env_gpu,
            orientation,
            sh: if sh_coeffs.is_empty() {
                None
            } else {
                Some(&sh_coeffs)
            },
            dp: dp.as_ref(),
            prefiltered: pre_buffer.as_ref(),
            mc: mc.as_ref().map(|m| (&m.accum, m.samples)),
            shadows: scene.shadows,
        },
    )?;
    records.push(PassRecord {
        kind: PassKind::Shade,
        timings: t,
    });
    let frame = frame.download(ctx)?;
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
    Ok(Rendered {
        frame,
        records,
        plan,
        mc: mc_summary,
    })
}
