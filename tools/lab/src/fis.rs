//! What accuracy costs in time: filtered importance sampling and plain BRDF-sampled Monte
//! Carlo at growing sample counts, each timed on the GPU and scored against a converged
//! Monte Carlo reference (MIS), on a sphere seen from normal incidence to grazing.

use envlight::error::Result;
use envlight::gpu::{total_ms, Context, Timed};
use envlight::math::brdf::Brdf;
use envlight::math::camera::sphere_camera;
use envlight::math::camera::Shape;
use envlight::math::envmap::luminance;
use envlight::math::fis::default_dp_size;
use envlight::math::{Mapping, Orientation};
use envlight::passes::gbuffer::{GBuffer, GBufferPass};
use envlight::passes::mc::{pixel_stats, McEnv, McOptions, MonteCarlo};
use envlight::passes::mip::MipChain;
use envlight::passes::shade::{Shade, ShadeInputs};
use envlight::passes::{ConvertOptions, Converter};
use envlight::scene::{Material, SceneObject, Technique};
use envlight::EnvMap;
use envlight::GpuEnvMap;
use std::path::PathBuf;

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
                    } = mc.run(&mc_g, &mc_env, &{
                        let mut o = McOptions::new(samples);
                        o.mis = mis;
                        o.seed = if mis { 7 } else { 3 };
                        o.per_frame = samples.min(256);
                        o
                    })?;
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
                            sh_rotation: envlight::passes::shade::Rotation::Zxzxz,
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

/// `envlight-lab fis`: FIS and plain BRDF-sampled MC against a converged MIS reference, on a
/// studio and a sun map (fis_vs_mc.csv, .md and .png; docs/fis/ holds them)
#[derive(clap::Args)]
pub struct FisArgs {
    /// Environment maps (default: the bundled sky)
    #[arg(long, value_delimiter = ',')]
    maps: Vec<PathBuf>,
    /// Image sides
    #[arg(long, value_delimiter = ',', default_value = "512,1024")]
    sizes: Vec<u32>,
    /// FIS sample counts
    #[arg(long, value_delimiter = ',', default_value = "1,4,16,64,256")]
    fis: Vec<u32>,
    /// Plain MC sample counts
    #[arg(long, value_delimiter = ',', default_value = "1,4,16,64,256,1024,4096")]
    mc: Vec<u32>,
    /// Samples per pixel of the MIS reference
    #[arg(long, default_value_t = 16384)]
    reference: u32,
    /// Lod biases swept at FIS 16 and 64
    #[arg(long, value_delimiter = ',', default_value = "-1,0,0.5,1,1.5,2,3", value_parser = crate::common::finite_f64)]
    biases: Vec<f64>,
    /// Output folder
    #[arg(long, default_value = "docs/fis")]
    out: PathBuf,
}

/// Runs `envlight-lab fis`: the rows, then their CSV, markdown and plot in `a.out`.
pub fn bench_fis(g: &crate::common::Global, a: &FisArgs) -> anyhow::Result<()> {
    use anyhow::Context as _;
    let ctx = crate::common::context(g)?;
    let default = [PathBuf::from("assets/sky_latlong.exr")];
    let paths = if a.maps.is_empty() {
        &default[..]
    } else {
        &a.maps[..]
    };
    let mut loaded = Vec::new();
    for p in paths {
        let m = envlight::io::load(p, &Default::default())?;
        let name = p
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_default();
        loaded.push((name, m));
    }
    let cfg = FisBench {
        sizes: a.sizes.clone(),
        fis: a.fis.clone(),
        mc: a.mc.clone(),
        reference: a.reference,
        biases: a.biases.clone(),
        bias_at: vec![16, 64],
        bias: envlight::scene::DEFAULT_FIS_BIAS,
    };
    let bar = indicatif::ProgressBar::new_spinner();
    let rows = run(&ctx, &loaded, &cfg, |m| bar.set_message(m.to_string()))?;
    bar.finish_and_clear();
    let out = &a.out;
    std::fs::create_dir_all(out).with_context(|| out.display().to_string())?;
    let device = format!("{} ({})", ctx.info().name, ctx.info().driver);
    std::fs::write(out.join("fis_vs_mc.csv"), crate::fis_report::csv(&rows))?;
    let md = crate::fis_report::markdown(&rows, &device);
    std::fs::write(out.join("fis_vs_mc.md"), &md)?;
    let png = out.join("fis_vs_mc.png");
    crate::fis_report::plot(&rows)
        .save(&png)
        .with_context(|| png.display().to_string())?;
    println!("{md}");
    Ok(())
}
