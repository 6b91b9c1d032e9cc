//! What accuracy costs in time: filtered importance sampling and plain BRDF-sampled Monte
//! Carlo at growing sample counts, each timed on the GPU and scored against a converged
//! Monte Carlo reference (MIS), on a sphere seen from normal incidence to grazing.

use crate::error::Result;
use crate::gpu::{total_ms, Context, Timed};
use crate::math::brdf::Brdf;
use crate::math::camera::sphere_camera;
use crate::math::camera::Shape;
use crate::math::envmap::luminance;
use crate::math::fis::default_dp_size;
use crate::math::{Mapping, Orientation};
use crate::passes::gbuffer::{GBuffer, GBufferPass};
use crate::passes::mc::{pixel_stats, McEnv, McOptions, MonteCarlo};
use crate::passes::mip::MipChain;
use crate::passes::shade::{Shade, ShadeInputs};
use crate::passes::{ConvertOptions, Converter};
use crate::scene::{Material, SceneObject, Technique};
use crate::EnvMap;
use crate::GpuEnvMap;

/// What to measure.
#[derive(Clone, Debug)]
pub struct FisBench {
    /// Image sides.
    pub sizes: Vec<u32>,
    /// FIS sample counts.
    pub fis: Vec<u32>,
    /// Plain Monte Carlo sample counts.
    pub mc: Vec<u32>,
    /// Samples per pixel of the MIS reference.
    pub reference: u32,
    /// Lod biases tried at the FIS counts of `bias_at`.
    pub biases: Vec<f64>,
    /// FIS counts at which the bias is swept.
    pub bias_at: Vec<u32>,
    /// The default bias used for the FIS rows.
    pub bias: f64,
}

/// One measurement.
#[derive(Clone, Debug)]
pub struct Row {
    /// Map name.
    pub map: String,
    /// Material.
    pub material: String,
    /// Image side.
    pub size: u32,
    /// "fis", "mc" or "fis-bias".
    pub technique: &'static str,
    /// Samples per pixel.
    pub samples: u32,
    /// Lod bias (FIS).
    pub bias: f64,
    /// GPU milliseconds for the frame (FIS: the shading draw; MC: all its frames).
    pub ms: f64,
    /// Relative RMS error of the luminance over the sphere against the reference.
    pub rms: f64,
}

/// The materials measured: GGX α ∈ {0.05, 0.3}, Phong n ∈ {10, 1000}.
pub fn materials() -> Vec<(String, Brdf)> {
    vec![
        (
            "ggx 0.05".into(),
            Brdf::Ggx {
                alpha: 0.05,
                correlated: false,
            },
        ),
        (
            "ggx 0.3".into(),
            Brdf::Ggx {
                alpha: 0.3,
                correlated: false,
            },
        ),
        ("phong 10".into(), Brdf::Phong { n: 10.0 }),
        ("phong 1000".into(), Brdf::Phong { n: 1000.0 }),
    ]
}

fn object(kind: Brdf, technique: Technique) -> SceneObject {
    SceneObject {
        shape: Shape::Sphere {
            center: [0.0; 3],
            radius: 1.0,
        },
        material: Material {
            kind,
            albedo: [1.0; 3],
            technique: Some(technique),
        },
    }
}

fn rms(frame: &[[f64; 3]], reference: &[[f64; 3]], mask: &[bool]) -> f64 {
    let (mut se, mut sr) = (0.0, 0.0);
    for ((a, b), m) in frame.iter().zip(reference).zip(mask) {
        if *m {
            let (la, lb) = (luminance(*a), luminance(*b));
            se += (la - lb) * (la - lb);
            sr += lb * lb;
        }
    }
    (se / sr.max(1e-300)).sqrt()
}

/// Runs the benchmark on each named map; `progress` is told what is being measured.
pub fn run(
    ctx: &Context,
    maps: &[(String, EnvMap)],
    cfg: &FisBench,
    mut progress: impl FnMut(&str),
) -> Result<Vec<Row>> {
    let mut rows = Vec::new();
    let conv = Converter::new(ctx)?;
    let mip = MipChain::new(ctx)?;
    let shade = Shade::new(ctx)?;
    let mc = MonteCarlo::new(ctx)?;
    let gpass = GBufferPass::new(ctx)?;
    for (name, map) in maps {
        let env_gpu = GpuEnvMap::upload(ctx, map)?;
        let Timed { value: dp, .. } = conv.run_mipped(
            &env_gpu,
            &ConvertOptions::new(Mapping::DualParaboloid, default_dp_size(map)),
        )?;
        mip.run(&dp)?;
        let Timed { value: mc_env, .. } =
            McEnv::for_map(ctx, &conv, map, &env_gpu, &Orientation::default())?;
        for &size in &cfg.sizes {
            let cam = sphere_camera(size);
            for (mname, kind) in materials() {
                let gbuf = |t: Technique| -> Result<GBuffer> {
                    Ok(gpass.run(&cam, &[object(kind, t).record(0)])?.value)
                };
                let mc_g = gbuf(Technique::Mc {
                    samples: 1,
                    error: None,
                })?;
                let mask: Vec<bool> = mc_g
                    .normal
                    .download(ctx)?
                    .texels
                    .iter()
                    .map(|t| t[0] != 0.0 || t[1] != 0.0 || t[2] != 0.0)
                    .collect();
                progress(&format!(
                    "{name} {mname} {size}²: reference, {} samples",
                    cfg.reference
                ));
                let run_mc = |samples: u32, mis: bool| -> Result<(Vec<[f64; 3]>, f64)> {
                    let Timed {
                        value: res,
                        timings: t,
                    } = mc.run(
                        &mc_g,
                        &mc_env,
                        &McOptions {
                            samples,
                            mis,
                            seed: if mis { 7 } else { 3 },
                            per_frame: samples.min(256),
                            ..Default::default()
                        },
                    )?;
                    let acc = res.accum.download_level(ctx, 0)?;
                    let mean = acc.iter().map(|&t| pixel_stats(t, res.samples).0).collect();
                    Ok((mean, total_ms(&t)))
                };
                let (reference, _) = run_mc(cfg.reference, true)?;
                let mut fis_rows =
                    |samples: u32, bias: f64, technique: &'static str| -> Result<()> {
                        let g = gbuf(Technique::Fis {
                            samples,
                            bias: Some(bias),
                            rotate: false,
                        })?;
                        let inputs = ShadeInputs {
                            env: &env_gpu,
                            orientation: Orientation::default(),
                            sh: None,
                            dp: Some(&dp),
                            prefiltered: None,
                            mc: None,
                            brdf_sh: None,
                            sh_rotation: crate::passes::shade::Rotation::Zxzxz,
                            split: None,
                            shadows: false,
                            lights: None,
                            footprint: Default::default(),
                        };
                        // The faster of two draws (the first may pay for warming caches).
                        let Timed { timings: t1, .. } = shade.run(&g, &inputs)?;
                        let Timed {
                            value: frame,
                            timings: t2,
                        } = shade.run(&g, &inputs)?;
                        let ms = t1[0].ms.min(t2[0].ms);
                        let f: Vec<[f64; 3]> = frame
                            .download(ctx)?
                            .texels
                            .iter()
                            .map(|t| t.map(f64::from))
                            .collect();
                        rows.push(Row {
                            map: name.clone(),
                            material: mname.clone(),
                            size,
                            technique,
                            samples,
                            bias,
                            ms,
                            rms: rms(&f, &reference, &mask),
                        });
                        Ok(())
                    };
                for &n in &cfg.fis {
                    progress(&format!("{name} {mname} {size}²: FIS {n}"));
                    fis_rows(n, cfg.bias, "fis")?;
                }
                for &n in &cfg.bias_at {
                    for &b in &cfg.biases {
                        fis_rows(n, b, "fis-bias")?;
                    }
                }
                for &n in &cfg.mc {
                    progress(&format!("{name} {mname} {size}²: MC {n}"));
                    let (f, ms) = run_mc(n, false)?;
                    rows.push(Row {
                        map: name.clone(),
                        material: mname.clone(),
                        size,
                        technique: "mc",
                        samples: n,
                        bias: 0.0,
                        ms,
                        rms: rms(&f, &reference, &mask),
                    });
                }
            }
        }
    }
    Ok(rows)
}
