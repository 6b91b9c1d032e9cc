//! What accuracy costs in time: filtered importance sampling and plain BRDF-sampled Monte
//! Carlo at growing sample counts, each timed on the GPU and scored against a converged
//! Monte Carlo reference (MIS), on a sphere seen from normal incidence to grazing.

use crate::envmap::luminance;
use crate::error::Result;
use crate::gpu::{Context, GpuEnvMap};
use crate::math::brdf::Brdf;
use crate::math::camera::{Camera, Projection, Shape};
use crate::math::{Mapping, Orientation};
use crate::passes::gbuffer::{GBuffer, GBufferPass};
use crate::passes::mc::{pixel_stats, McEnv, McOptions, MonteCarlo};
use crate::passes::mip::MipChain;
use crate::passes::shade::{Shade, ShadeInputs};
use crate::passes::{ConvertOptions, Converter};
use crate::render::{default_dp_size, object_record};
use crate::scene::{Material, SceneObject, Technique};
use crate::EnvMap;

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

/// An orthographic camera whose `size`² image a unit sphere at the origin fills, so that the
/// view angle runs from normal incidence to grazing.
pub fn sphere_camera(size: u32) -> Camera {
    Camera {
        projection: Projection::Orthographic { height: 2.1 },
        eye: [0.0, 0.3, 5.0],
        target: [0.0, 0.0, 0.0],
        up: [0.0, 1.0, 0.0],
        width: size,
        height: size,
    }
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
        let (dp, _) = conv.run_mipped(
            &env_gpu,
            &ConvertOptions {
                to: Mapping::DualParaboloid,
                size: default_dp_size(map),
                orientation: Orientation::default(),
                supersample: None,
            },
        )?;
        mip.run(&dp)?;
        let (mc_env, _) = McEnv::for_map(ctx, &conv, map, &env_gpu, &Orientation::default())?;
        for &size in &cfg.sizes {
            let cam = sphere_camera(size);
            for (mname, kind) in materials() {
                let gbuf = |t: Technique| -> Result<GBuffer> {
                    Ok(gpass.run(&cam, &[object_record(&object(kind, t), 0)])?.0)
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
                    let (res, t) = mc.run(
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
                    Ok((mean, t.iter().map(|t| t.ms).sum()))
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
                            shadows: false,
                        };
                        // The faster of two draws (the first may pay for warming caches).
                        let (_, t1) = shade.run(&g, &inputs)?;
                        let (frame, t2) = shade.run(&g, &inputs)?;
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

/// The rows as CSV.
pub fn csv(rows: &[Row]) -> String {
    let mut s = String::from("map,material,size,technique,samples,bias,gpu_ms,relative_rms\n");
    for r in rows {
        s += &format!(
            "{},{},{},{},{},{},{:.4},{:.6}\n",
            r.map, r.material, r.size, r.technique, r.samples, r.bias, r.ms, r.rms
        );
    }
    s
}

/// Plain MC samples needed to match an error, by log-log interpolation of the MC curve, and
/// the time that takes; None when even the largest count does not reach it.
pub fn mc_to_match(mc: &[&Row], target: f64) -> Option<(f64, f64)> {
    for w in mc.windows(2) {
        let (a, b) = (w[0], w[1]);
        if a.rms >= target && b.rms <= target {
            let t = if (a.rms / b.rms).ln().abs() < 1e-12 {
                0.0
            } else {
                (a.rms / target).ln() / (a.rms / b.rms).ln()
            };
            let n =
                (a.samples as f64).ln() + t * ((b.samples as f64).ln() - (a.samples as f64).ln());
            let ms = a.ms.ln() + t * (b.ms.ln() - a.ms.ln());
            return Some((n.exp(), ms.exp()));
        }
    }
    mc.first()
        .filter(|a| a.rms <= target)
        .map(|a| (a.samples as f64, a.ms))
}

/// A markdown report: the full table, the bias sweep, and the headline (MC samples and time
/// to match FIS at 16 and 64).
pub fn markdown(rows: &[Row], device: &str) -> String {
    let mut s = format!("Device: {device}. Relative RMS of luminance over the sphere against MIS Monte Carlo; GPU ms from timestamp queries.\n\n");
    s += "| map | material | size | technique | N | bias | GPU ms | rel. RMS |\n|---|---|---|---|---|---|---|---|\n";
    for r in rows.iter().filter(|r| r.technique != "fis-bias") {
        s += &format!(
            "| {} | {} | {} | {} | {} | {} | {:.3} | {:.4} |\n",
            r.map,
            r.material,
            r.size,
            r.technique,
            r.samples,
            if r.technique == "fis" {
                format!("{}", r.bias)
            } else {
                "-".into()
            },
            r.ms,
            r.rms
        );
    }
    let sweep: Vec<&Row> = rows.iter().filter(|r| r.technique == "fis-bias").collect();
    if !sweep.is_empty() {
        s += "\n### Lod bias sweep (relative RMS, mean over maps and materials)\n\n| N | bias | mean rel. RMS |\n|---|---|---|\n";
        let mut keys: Vec<(u32, f64)> = sweep.iter().map(|r| (r.samples, r.bias)).collect();
        keys.sort_by(|a, b| a.0.cmp(&b.0).then(a.1.total_cmp(&b.1)));
        keys.dedup();
        for (n, b) in keys {
            let v: Vec<f64> = sweep
                .iter()
                .filter(|r| r.samples == n && r.bias == b)
                .map(|r| r.rms)
                .collect();
            s += &format!(
                "| {n} | {b} | {:.4} |\n",
                v.iter().sum::<f64>() / v.len() as f64
            );
        }
    }
    s += "\n### Headline: plain MC samples to match FIS\n\n| map | material | size | FIS N | FIS rel. RMS | FIS ms | MC N to match | MC ms | time ratio MC/FIS |\n|---|---|---|---|---|---|---|---|---|\n";
    for f in rows
        .iter()
        .filter(|r| r.technique == "fis" && (r.samples == 16 || r.samples == 64))
    {
        let mc: Vec<&Row> = rows
            .iter()
            .filter(|r| {
                r.technique == "mc"
                    && r.map == f.map
                    && r.material == f.material
                    && r.size == f.size
            })
            .collect();
        match mc_to_match(&mc, f.rms) {
            Some((n, ms)) => {
                s += &format!(
                    "| {} | {} | {} | {} | {:.4} | {:.3} | {:.0} | {:.3} | {:.1} |\n",
                    f.map,
                    f.material,
                    f.size,
                    f.samples,
                    f.rms,
                    f.ms,
                    n,
                    ms,
                    ms / f.ms
                )
            }
            None => {
                s += &format!(
                    "| {} | {} | {} | {} | {:.4} | {:.3} | > {} | - | - |\n",
                    f.map,
                    f.material,
                    f.size,
                    f.samples,
                    f.rms,
                    f.ms,
                    mc.last().map(|r| r.samples).unwrap_or(0)
                )
            }
        }
    }
    s
}

/// Relative RMS error (y, log, a gridline per decade) against GPU ms (x, log, a gridline per
/// decade), one curve per (technique, material, map, size), coloured by material in the
/// accuracy plot's palette: FIS solid with filled points, plain MC dotted with hollow points.
pub fn plot(rows: &[Row]) -> image::RgbImage {
    let (w, h, m) = (720u32, 480u32, 40.0f64);
    let mut img = image::RgbImage::from_pixel(w, h, image::Rgb([255, 255, 255]));
    let pts: Vec<&Row> = rows
        .iter()
        .filter(|r| r.technique != "fis-bias" && r.ms > 0.0 && r.rms > 0.0)
        .collect();
    if pts.is_empty() {
        return img;
    }
    let (lx0, lx1) = pts.iter().fold((f64::MAX, f64::MIN), |(a, b), r| {
        (a.min(r.ms.log10()), b.max(r.ms.log10()))
    });
    let (ly0, ly1) = pts.iter().fold((f64::MAX, f64::MIN), |(a, b), r| {
        (a.min(r.rms.log10()), b.max(r.rms.log10()))
    });
    let (lx0, lx1, ly0, ly1) = (lx0.floor(), lx1.ceil(), ly0.floor(), ly1.ceil());
    let x_of = |ms: f64| m + (ms.log10() - lx0) / (lx1 - lx0).max(1e-9) * (w as f64 - 2.0 * m);
    let y_of = |e: f64| m + (ly1 - e.log10()) / (ly1 - ly0).max(1e-9) * (h as f64 - 2.0 * m);
    let put = |img: &mut image::RgbImage, x: i32, y: i32, c: [u8; 3]| {
        if x >= 0 && y >= 0 && (x as u32) < w && (y as u32) < h {
            img.put_pixel(x as u32, y as u32, image::Rgb(c));
        }
    };
    for d in lx0 as i32..=lx1 as i32 {
        let x = x_of(10f64.powi(d)) as i32;
        for y in m as i32..(h as i32 - m as i32) {
            put(&mut img, x, y, [225, 225, 225]);
        }
    }
    for d in ly0 as i32..=ly1 as i32 {
        let y = y_of(10f64.powi(d)) as i32;
        for x in m as i32..(w as i32 - m as i32) {
            put(&mut img, x, y, [225, 225, 225]);
        }
    }
    let mut curves: Vec<(String, Vec<&Row>)> = Vec::new();
    for r in &pts {
        let key = format!("{} {} {} {}", r.technique, r.material, r.map, r.size);
        match curves.iter_mut().find(|c| c.0 == key) {
            Some(c) => c.1.push(r),
            None => curves.push((key, vec![r])),
        }
    }
    let mats: Vec<String> = materials().into_iter().map(|m| m.0).collect();
    for (_, c) in &curves {
        let mi = mats.iter().position(|m| *m == c[0].material).unwrap_or(0);
        let colour = crate::accuracy::plot_colour(mi);
        let fis = c[0].technique == "fis";
        for pair in c.windows(2) {
            let (a, b) = (
                (x_of(pair[0].ms), y_of(pair[0].rms)),
                (x_of(pair[1].ms), y_of(pair[1].rms)),
            );
            let n = ((b.0 - a.0).abs().max((b.1 - a.1).abs()) as usize).max(1);
            for k in 0..=n {
                let t = k as f64 / n as f64;
                let (x, y) = (a.0 + t * (b.0 - a.0), a.1 + t * (b.1 - a.1));
                // FIS: solid lines; MC: dotted.
                if fis || (k / 4) % 2 == 0 {
                    put(&mut img, x as i32, y as i32, colour);
                    put(&mut img, x as i32, y as i32 + 1, colour);
                }
            }
        }
        for r in c {
            let (x, y) = (x_of(r.ms) as i32, y_of(r.rms) as i32);
            for dy in -3..=3 {
                for dx in -3..=3 {
                    let edge = dx * dx + dy * dy >= 6;
                    if fis || edge {
                        put(&mut img, x + dx, y + dy, colour);
                    }
                }
            }
        }
    }
    img
}
