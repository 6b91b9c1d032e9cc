//! Every pass's GPU time beside its floor, a copy of the same input
//! (one read and one write of each of its texels, `passes::testing::copy`), and its error, at
//! several sizes of one lat-long map — a roofline table a GPU timer reads at a glance.

use super::{median, Report};
use crate::abi::SH_MAX_LMAX;
use crate::error::Result;
use crate::gpu::{total_ms, Context, Timed, Timing};
use crate::math::brdf::Brdf;
use crate::math::camera::{Camera, Projection};
use crate::math::exact::ExactFilter;
use crate::math::filter::{Kernel, Prepared};
use crate::math::lights::{
    extract, extract_blocks, light_sum, prepare, record_block, BlockExtraction, ExtractOptions,
    LightKernel,
};
use crate::math::split_sum::level_alpha;
use crate::math::synth::Sky;
use crate::math::{mip, sh};
use crate::passes::sh_project::Subgroups;
use crate::passes::testing::copy::CopyPass;
use crate::passes::{
    BruteFilter, ConvertOptions, Converter, FilterTarget, GpuLights, LightsPass, MipChain,
    PrefilterOptions, ShEvaluator, ShProjector, SplitSum,
};
use crate::render::score::{errors, scene, sphere_pixels, truth};
use crate::render::{PassKind, Renderer};
use crate::scene::{LookupFilter, SplitSumSettings, Technique};
use crate::{EnvMap, GpuEnvMap, Mapping, Orientation};
use glam::{DMat3, DVec3};

/// One pass at one size: its GPU time, its floor's, and its error in words.
struct Row {
    input: String,
    pass: String,
    ms: f64,
    floor: f64,
    error: String,
}

/// The median of `reps` runs' total GPU time, after one untimed run (pipelines, warm-up).
pub(crate) fn time(reps: usize, mut run: impl FnMut() -> Result<Vec<Timing>>) -> Result<f64> {
    run()?;
    let mut ms = Vec::new();
    for _ in 0..reps.max(1) {
        ms.push(total_ms(&run()?));
    }
    Ok(median(ms))
}

/// The GPU time of a copy of a `mapping` map `w` × `h` (the floor of a pass reading or
/// writing one).
pub(super) fn copy_ms(
    ctx: &Context,
    copy: &CopyPass,
    mapping: Mapping,
    w: u32,
    h: u32,
    reps: usize,
) -> Result<f64> {
    let map = GpuEnvMap::new(ctx, "floor source", mapping, w, h)?;
    ctx.run("clearing the floor's source", |rec| {
        rec.clear(&map.image, [1.0; 4]);
        Ok(())
    })?;
    time(reps, || Ok(copy.run(&map)?.timings))
}

/// |power out / power in − 1| in the worst channel.
fn power_error(out: &EnvMap, src: &EnvMap) -> f64 {
    let (p, q) = (out.power(), src.power());
    (0..3).map(|c| (p[c] / q[c] - 1.0).abs()).fold(0.0, worse)
}

/// The larger of two errors, NaN where either is.
pub(super) fn worse(a: f64, b: f64) -> f64 {
    if a.is_nan() || b.is_nan() {
        f64::NAN
    } else {
        a.max(b)
    }
}

/// Relative luminance error of a GPU texel against a float64 value.
pub(super) fn rel_lum(got: [f32; 4], want: [f64; 3]) -> f64 {
    let y = |c: [f64; 3]| crate::math::envmap::luminance(c);
    let w = y(want);
    (y([got[0] as f64, got[1] as f64, got[2] as f64]) - w).abs() / w.abs().max(1e-30)
}

/// Texels per level where a GGX chain and an irradiance cube are scored (all of a level that
/// has fewer, [`spread_texels`]).
pub(super) const ERROR_TEXELS: usize = 256;

/// Texel centres of a cube level `s` a side where errors are measured: all of them when the
/// level has at most `n`, else `n` spread evenly over the faces and within each face (the R2
/// sequence: point k on face k mod 6 at the fractional parts of ½ + k·(1/g, 1/g²), g the
/// plastic number), so no row, column or face is favoured.
pub(super) fn spread_texels(s: u32, n: usize) -> Vec<(usize, DVec3)> {
    let at = |face: u32, i: u32, j: u32| {
        let d = Mapping::Cube.coord_to_dir(Mapping::texel_center(s, s, face, i, j));
        (((face * s + j) * s + i) as usize, d)
    };
    let all = 6 * s as usize * s as usize;
    if all <= n {
        return (0..all as u32)
            .map(|t| at(t / (s * s), t % s, (t / s) % s))
            .collect();
    }
    const G: [f64; 2] = [0.754_877_666_246_692_7, 0.569_840_290_998_053_3];
    (0..n)
        .map(|k| {
            let cell = |g: f64| ((((0.5 + k as f64 * g).fract()) * s as f64) as u32).min(s - 1);
            at((k % 6) as u32, cell(G[0]), cell(G[1]))
        })
        .collect()
}

/// Eight texel centres of a cube level `s` a side, spread over the faces.
pub(super) fn probe_texels(s: u32) -> Vec<(usize, DVec3)> {
    (0..8u32)
        .map(|q| {
            let (face, i, j) = (q % 6, (q * 37 + 11) % s, (q * 23 + 5) % s);
            let d = Mapping::Cube.coord_to_dir(Mapping::texel_center(s, s, face, i, j));
            (((face * s + j) * s + i) as usize, d)
        })
        .collect()
}

/// The upload, the conversions and the MIP chain of `map`.
fn map_rows(
    ctx: &Context,
    map: &EnvMap,
    src: &GpuEnvMap,
    floor: f64,
    reps: usize,
) -> Result<Vec<Row>> {
    let (w, h) = (map.width, map.height);
    let input = format!("latlong {w}x{h}");
    let mut rows = Vec::new();
    let up = GpuEnvMap::new(ctx, "upload", map.mapping, w, h)?;
    let ms = time(reps, || {
        Ok(ctx
            .run("upload", |rec| {
                rec.span("upload", |rec| up.record_upload(rec, map))
            })?
            .timings)
    })?;
    let back = up.download(ctx)?;
    let differ = back
        .texels
        .iter()
        .zip(&map.texels)
        .filter(|(a, b)| a != b)
        .count();
    rows.push(Row {
        input: input.clone(),
        pass: "upload (staging buffer to image)".into(),
        ms,
        floor,
        error: format!("{differ} texels differ"),
    });
    let conv = Converter::new(ctx)?;
    let cases = [
        (Mapping::Cube, w / 4, "areas"),
        (Mapping::DualParaboloid, w / 2, "areas"),
        (Mapping::Angular, w / 2, "supersampled"),
        (Mapping::LatLong, w, "supersampled"),
    ];
    let mut dp = None;
    for (to, size, how) in cases {
        let opts = ConvertOptions::new(to, size);
        // Where the area conversion does not serve this size on this device (a slope
        // buffer past the device's storage buffer range), the converter samples instead, and
        // the row says so.
        let areas = how == "areas" && conv.uses_area((Mapping::LatLong, w, h), &opts);
        let how = match (how, areas) {
            ("areas", false) => "supersampled: areas do not serve this size on this device",
            _ => how,
        };
        let ms = time(reps, || Ok(conv.run(src, &opts)?.timings))?;
        let Timed { value: out, .. } = conv.run(src, &opts)?;
        let e = power_error(&out.download(ctx)?, map);
        rows.push(Row {
            input: input.clone(),
            pass: format!("convert to {} {size} ({how})", to.name()),
            ms,
            floor,
            error: format!("power {e:.1e}"),
        });
        if to == Mapping::DualParaboloid {
            dp = Some(conv.run_mipped(src, &opts)?.value);
        }
        if areas {
            rows.extend(planned_row(ctx, &conv, (map, src), &opts, floor, reps)?);
        }
    }
    let Some(dp) = dp else {
        unreachable!("the cases convert to a paraboloid")
    };
    let mips = MipChain::new(ctx)?;
    let dp_opts = ConvertOptions::new(Mapping::DualParaboloid, dp.width);
    // Each run on a fresh paraboloid: the chain premultiplies level 0 in place.
    let ms = time(reps, || mips.run(&conv.run_mipped(src, &dp_opts)?.value))?;
    let level0 = dp.download(ctx)?;
    mips.run(&dp)?;
    let want = mip::chain(&level0);
    let mut worst = 0.0f64;
    for (k, l) in want.iter().enumerate() {
        let got = dp.download_level(ctx, k as u32)?;
        for (g, t) in got.iter().zip(&l.texels) {
            if g[3] > 0.0 && t[3] > 0.0 {
                for c in 0..3 {
                    let w = t[c] / t[3];
                    worst = worse(worst, ((g[c] / g[3]) as f64 - w).abs() / w.abs().max(1e-30));
                }
            }
        }
    }
    let dp_floor = copy_ms(
        ctx,
        &CopyPass::new(ctx)?,
        Mapping::DualParaboloid,
        dp.width,
        dp.height,
        reps,
    )?;
    rows.push(Row {
        input: format!("dual paraboloid {}", dp.width),
        pass: format!("MIP chain, {} levels", dp.mips()),
        ms,
        floor: dp_floor,
        error: format!("twin {worst:.1e}"),
    });
    Ok(rows)
}

/// The area conversion with `opts` from a plan made once (`Converter::plan`): the gather's
/// time (the source's slopes included), its power error and the plan's host time and size;
/// none where the plan would not fit the device's largest storage buffer.
fn planned_row(
    ctx: &Context,
    conv: &Converter,
    (map, src): (&EnvMap, &GpuEnvMap),
    opts: &ConvertOptions,
    floor: f64,
    reps: usize,
) -> Result<Option<Row>> {
    let shape = (src.mapping, src.width, src.height);
    if Converter::plan_bytes(shape, opts) > ctx.info().max_storage_buffer_range {
        return Ok(None);
    }
    let started = std::time::Instant::now();
    let plan = match conv.plan(shape, opts) {
        Ok(plan) => plan,
        Err(crate::Error::Invalid(why)) if why.contains("maxStorageBufferRange") => {
            return Ok(None)
        }
        Err(e) => return Err(e),
    };
    let built = started.elapsed().as_secs_f64() * 1e3;
    let ms = time(reps, || Ok(conv.run_planned(src, &plan)?.timings))?;
    let Timed { value: out, .. } = conv.run_planned(src, &plan)?;
    let e = power_error(&out.download(ctx)?, map);
    Ok(Some(Row {
        input: format!("latlong {}x{}", map.width, map.height),
        pass: format!(
            "convert to {} {} (areas, planned)",
            opts.to.name(),
            opts.size
        ),
        ms,
        floor,
        error: format!(
            "power {e:.1e}; plan made once: {built:.0} ms on the host, {:.1} MB",
            plan.bytes() as f64 / 1e6
        ),
    }))
}

/// The SH projection at every order and the irradiance evaluation at orders 2 and 8.
fn sh_rows(
    ctx: &Context,
    map: &EnvMap,
    src: &GpuEnvMap,
    floor: f64,
    reps: usize,
) -> Result<Vec<Row>> {
    let input = format!("latlong {}x{}", map.width, map.height);
    let proj = ShProjector::new(ctx, Subgroups::Auto)?;
    // Coefficient k does not depend on the order projected to: one float64 projection.
    let cpu = sh::project(map, SH_MAX_LMAX);
    let l00 = cpu[0].iter().fold(0.0f64, |a, c| worse(a, c.abs()));
    let mut rows = Vec::new();
    for lmax in 0..=SH_MAX_LMAX {
        let ms = time(reps, || Ok(proj.run(src, lmax)?.timings))?;
        let Timed { value: gpu, .. } = proj.run(src, lmax)?;
        let mut worst = 0.0f64;
        for (g, c) in gpu.coeffs.iter().zip(&cpu) {
            for ch in 0..3 {
                worst = worse(worst, (g[ch] - c[ch]).abs() / l00);
            }
        }
        rows.push(Row {
            input: input.clone(),
            pass: format!("SH projection, l = {lmax}"),
            ms,
            floor,
            error: format!("twin {worst:.1e} of L00"),
        });
    }
    let eval = ShEvaluator::new(ctx)?;
    let target = FilterTarget {
        to: Mapping::Cube,
        size: 32,
    };
    let out_floor = copy_ms(ctx, &CopyPass::new(ctx)?, Mapping::Cube, 32, 32, reps)?;
    for lmax in [2u32, 8] {
        let irr = sh::irradiance_coeffs(&cpu[..sh::count(lmax)]);
        let ms = time(reps, || Ok(eval.run(&irr, target)?.timings))?;
        let Timed { value: out, .. } = eval.run(&irr, target)?;
        let out = out.download(ctx)?;
        let e00 = irr[0][1].abs();
        let mut worst = 0.0f64;
        for (k, t) in out.texels.iter().enumerate() {
            let (face, j, i) = (k as u32 / 1024, (k as u32 / 32) % 32, k as u32 % 32);
            let d = Mapping::Cube.coord_to_dir(Mapping::texel_center(32, 32, face, i, j));
            let want = sh::eval(&irr, d);
            for ch in 0..3 {
                worst = worse(worst, (t[ch] as f64 - want[ch].max(0.0)).abs() / e00);
            }
        }
        rows.push(Row {
            input: format!("{} coefficients", sh::count(lmax)),
            pass: format!("SH irradiance into a 32² cube, l = {lmax}"),
            ms,
            floor: out_floor,
            error: format!("twin {worst:.1e} of E00"),
        });
    }
    Ok(rows)
}

/// The brute-force irradiance and Phong filters (into an 8² cube: they sum every source
/// texel for every output texel), the GGX chain and the lights pass, each against its float64
/// exact filter.
fn filter_rows(
    ctx: &Context,
    map: &EnvMap,
    src: &GpuEnvMap,
    floor: f64,
    reps: usize,
) -> Result<Vec<Row>> {
    let input = format!("latlong {}x{}", map.width, map.height);
    let o = Orientation::default();
    let exact = ExactFilter::new(map, DMat3::IDENTITY);
    let prepared = Prepared::new(map, DMat3::IDENTITY);
    let brute = BruteFilter::new(ctx)?;
    let target = FilterTarget {
        to: Mapping::Cube,
        size: 8,
    };
    let mut rows = Vec::new();
    for (kernel, name) in [
        (Kernel::Cosine, "irradiance (brute force)"),
        (
            Kernel::Phong { n: 64.0 },
            "Phong 64 prefilter (brute force)",
        ),
    ] {
        let ms = time(reps, || Ok(brute.run(src, &o, kernel, target)?.timings))?;
        let out = brute
            .run(src, &o, kernel, target)?
            .value
            .download_level(ctx, 0)?;
        let worst = probe_texels(8)
            .into_iter()
            .map(|(k, d)| {
                let want = match kernel {
                    Kernel::Cosine => exact.irradiance(d),
                    Kernel::Phong { .. } => prepared.convolve(kernel, d),
                };
                rel_lum(out[k], want)
            })
            .fold(0.0, worse);
        rows.push(Row {
            input: input.clone(),
            pass: format!("{name} into an 8² cube"),
            ms,
            floor,
            error: format!("exact {worst:.1e} (8 texels)"),
        });
    }
    rows.push(ggx_chain_row(ctx, map, reps)?);
    rows.push(lights_row(ctx, map, reps)?);
    Ok(rows)
}

/// The split-sum GGX chain (7 levels of a 128² cube, 64 samples) as the product runs it:
/// from the paraboloid (with its MIP chain) of the map's residual, its lights taken out on the
/// host by the renderer's chain rule ([`ExtractOptions::chain`]: above twice the mean, the
/// residual filled under them), against the exact GGX prefilter of that residual at
/// [`ERROR_TEXELS`] texels of each level from 1.
fn ggx_chain_row(ctx: &Context, map: &EnvMap, reps: usize) -> Result<Row> {
    let size = (map.width / 2).min(512);
    let residual = extract(map, &ExtractOptions::chain()).residual;
    let src = GpuEnvMap::upload(ctx, &residual)?;
    let conv = Converter::new(ctx)?;
    let opts = ConvertOptions::new(Mapping::DualParaboloid, size).for_residual_chain((
        map.mapping,
        map.width,
        map.height,
    ));
    let Timed { value: dp, .. } = conv.run_mipped(&src, &opts)?;
    MipChain::new(ctx)?.run(&dp)?;
    let pass = SplitSum::new(ctx)?;
    let levels = 7;
    let chain = SplitSum::cube_chain(ctx, 128, levels)?;
    let mut opts = PrefilterOptions::new(levels);
    opts.samples = 64;
    let record = || {
        Ok(ctx
            .run("ggx chain", |rec| {
                pass.record_prefilter(rec, &dp, &chain, &opts)
            })?
            .timings)
    };
    let ms = time(reps, record)?;
    // Per level the mean over its texels; the worst level's mean, and the worst texel.
    let exact = ExactFilter::new(&residual, DMat3::IDENTITY);
    let (mut worst_mean, mut worst) = (0.0f64, 0.0f64);
    for k in 1..levels {
        let s = (128u32 >> k).max(1);
        let got = chain.download_level(ctx, k)?;
        let e: Vec<f64> = spread_texels(s, ERROR_TEXELS)
            .into_iter()
            .map(|(t, d)| rel_lum(got[t], exact.ggx(d, level_alpha(k, levels))))
            .collect();
        worst_mean = worse(worst_mean, e.iter().sum::<f64>() / e.len() as f64);
        worst = e.into_iter().fold(worst, worse);
    }
    let floor = copy_ms(
        ctx,
        &CopyPass::new(ctx)?,
        Mapping::DualParaboloid,
        size,
        size,
        reps,
    )?;
    Ok(Row {
        input: format!("dual paraboloid {size} of the residual, with its chain"),
        pass: format!("GGX chain, cube 128², {levels} levels, 64 samples"),
        ms,
        floor,
        error: format!(
            "exact (of the residual): worst level's mean {worst_mean:.1e}, worst texel \
             {worst:.1e} ({} a level, or all of a smaller one)",
            ERROR_TEXELS
        ),
    })
}

/// The lights pass: the map's extracted lights (the default rule, on the host, as a bake
/// extracts them: records no finer than `RECORD_WIDTH`'s texels, so that a 4096 × 2048 sun
/// is the same records as at 1024 × 512 rather than a plateau past the cap) filtered by the
/// cosine into a 32² cube, against their float64 sum at every texel.
fn lights_row(ctx: &Context, map: &EnvMap, reps: usize) -> Result<Row> {
    let block = record_block(map, crate::abi::lights::RECORD_WIDTH);
    let BlockExtraction { grid, extraction } =
        extract_blocks(map, &ExtractOptions::default(), block);
    let prepared = prepare(
        grid.as_ref().unwrap_or(map),
        &extraction,
        DMat3::IDENTITY,
        0.02,
    );
    if prepared.is_empty() {
        return Err(crate::Error::Invalid(format!(
            "floors: the {}x{} source has no light texels to filter",
            map.width, map.height
        )));
    }
    let gpu = GpuLights::upload(ctx, &prepared)?;
    let pass = LightsPass::new(ctx)?;
    let cube = SplitSum::cube_chain(ctx, 32, 1)?;
    let kernel = LightKernel::Cosine;
    let record = || {
        Ok(ctx
            .run("lights", |rec| {
                rec.clear(&cube.image, [0.0; 4]);
                pass.record(rec, &gpu, kernel, &cube, 0)
            })?
            .timings)
    };
    let ms = time(reps, record)?;
    let got = cube.download_level(ctx, 0)?;
    let mut top = 0.0f64;
    let mut worst = 0.0f64;
    let wants: Vec<[f64; 3]> = (0..6 * 32 * 32u32)
        .map(|t| {
            let d = Mapping::Cube.coord_to_dir(Mapping::texel_center(
                32,
                32,
                t / 1024,
                t % 32,
                (t / 32) % 32,
            ));
            light_sum(&prepared, d, kernel)
        })
        .collect();
    for w in &wants {
        top = worse(top, w[1]);
    }
    for (g, w) in got.iter().zip(&wants) {
        for c in 0..3 {
            worst = worse(worst, (g[c] as f64 - w[c]).abs() / top);
        }
    }
    let floor = copy_ms(ctx, &CopyPass::new(ctx)?, Mapping::Cube, 32, 32, reps)?;
    let records = match block {
        1 => format!("{} light texels", prepared.len()),
        b => format!("{} light records ({b}² texels each)", prepared.len()),
    };
    Ok(Row {
        input: records,
        pass: "lights (cosine) into a 32² cube".into(),
        ms,
        floor,
        error: format!("twin {worst:.1e} of the largest"),
    })
}

/// The shade pass per technique: its GPU time drawing a 128² frame of a unit sphere
/// (orthographic), against a copy of that frame; its error, the technique's, against two
/// 1024-spp Monte Carlo renders of a 32² frame (relative RMS; their own noise beside it).
fn shade_rows(ctx: &Context, map: &EnvMap, reps: usize) -> Result<Vec<Row>> {
    let renderer = Renderer::new(ctx);
    let camera = |side| Camera {
        projection: Projection::Orthographic { height: 2.2 },
        eye: [0.0, 0.0, 5.0],
        target: [0.0; 3],
        up: [0.0, 1.0, 0.0],
        width: side,
        height: side,
    };
    let (big, small) = (camera(128), camera(32));
    let floor = copy_ms(ctx, &CopyPass::new(ctx)?, Mapping::LatLong, 128, 128, reps)?;
    let split = SplitSumSettings::default();
    let ggx = Brdf::Ggx {
        alpha: 0.3,
        correlated: true,
    };
    let fis = |samples| Technique::Fis {
        samples,
        bias: None,
        rotate: true,
    };
    let cases = [
        (
            Brdf::Mirror,
            Technique::Lookup,
            "mirror, lookup (one texel a pixel)",
        ),
        (
            Brdf::Mirror,
            Technique::Lookup,
            "mirror, lookup filtered over each pixel's footprint",
        ),
        (
            Brdf::Lambert,
            Technique::Sh { order: 2 },
            "diffuse, SH l = 2",
        ),
        (
            Brdf::Lambert,
            Technique::Sh { order: 8 },
            "diffuse, SH l = 8",
        ),
        (
            Brdf::Lambert,
            Technique::Prefiltered { size: 32 },
            "diffuse, prefiltered 32",
        ),
        (ggx, fis(64), "GGX 0.3, FIS 64"),
        (ggx, Technique::SplitSum, "GGX 0.3, split-sum"),
        (
            ggx,
            Technique::Mc {
                samples: 64,
                error: None,
            },
            "GGX 0.3, Monte Carlo 64",
        ),
    ];
    let mut references: Vec<(Brdf, (EnvMap, f64))> = Vec::new();
    let mut rows = Vec::new();
    for (brdf, t, name) in cases {
        // The mirror twice: point lookups, then the footprint filter (`auto`'s choice for a
        // mirror); the other techniques under the default.
        let filter = match (brdf, name.contains("footprint")) {
            (Brdf::Mirror, true) => LookupFilter::Footprint,
            (Brdf::Mirror, false) => LookupFilter::Point,
            _ => LookupFilter::default(),
        };
        let shade_ms = |cam| -> Result<Vec<Timing>> {
            let mut sc = scene(cam, brdf, t, None, 1, split);
            sc.environment.filter = filter;
            let r = renderer.render(&sc, map)?;
            Ok(r.records
                .into_iter()
                .filter(|p| p.kind == PassKind::Shade)
                .flat_map(|p| p.timings)
                .collect())
        };
        let ms = time(reps, || shade_ms(big))?;
        let error = if brdf == Brdf::Mirror && filter == LookupFilter::Point {
            "— (a lookup: no integral to err)".to_string()
        } else if brdf == Brdf::Mirror {
            "— (each pixel's footprint mean: docs/accuracy.md's mirror rows)".to_string()
        } else {
            if !references.iter().any(|r| r.0 == brdf) {
                let r = truth(&renderer, small, brdf, None, split, 1024, map)?;
                references.push((brdf, r));
            }
            let Some((_, (want, noise))) = references.iter().find(|r| r.0 == brdf) else {
                unreachable!("made above")
            };
            let got = renderer.render(&scene(small, brdf, t, None, 1, split), map)?;
            let (rms, ..) = errors(&got.frame, want, &sphere_pixels(&small));
            format!(
                "{:.2}% rel. RMS (reference noise {:.2}%)",
                100.0 * rms,
                100.0 * noise
            )
        };
        rows.push(Row {
            input: "G-buffer 128²".into(),
            pass: format!("shade: {name}"),
            ms,
            floor,
            error,
        });
    }
    Ok(rows)
}

/// Every pass against its floor at each lat-long width in `sizes` (the analytic sky, a sun
/// 10⁵ × the zenith), the median of `reps` timed runs; `progress` hears of each width done.
/// The report's job is "floors".
pub fn floors(
    ctx: &Context,
    sizes: &[u32],
    reps: usize,
    progress: &dyn Fn(&str),
) -> Result<Report> {
    let copy = CopyPass::new(ctx)?;
    let mut rows = Vec::new();
    for &w in sizes {
        let map = EnvMap::from_fn(Mapping::LatLong, w, w / 2, 2, |d| {
            Sky::default().radiance(d)
        });
        let src = GpuEnvMap::upload(ctx, &map)?;
        let floor = time(reps, || Ok(copy.run(&src)?.timings))?;
        rows.push(Row {
            input: format!("latlong {w}x{}", w / 2),
            pass: "copy (the floor)".into(),
            ms: floor,
            floor,
            error: "—".into(),
        });
        rows.extend(map_rows(ctx, &map, &src, floor, reps)?);
        rows.extend(sh_rows(ctx, &map, &src, floor, reps)?);
        rows.extend(filter_rows(ctx, &map, &src, floor, reps)?);
        rows.extend(shade_rows(ctx, &map, reps)?);
        progress(&format!("floors: latlong {w}: done"));
    }
    let method = format!(
        "GPU time from timestamps, the median of {reps} runs after an untimed one. Each pass's \
         floor is a copy of its input (every texel read once and written once by \
         `passes::testing::copy`), measured in the same run: of the source map, of the \
         paraboloid, or of the output where the input is small (coefficients, lights, the \
         G-buffer); the ratio is the pass's time over it. Errors: power (conversions), the \
         float64 twin (upload, MIP chain, SH, lights), the exact filter at 8 texels \
         (brute force) or at {ERROR_TEXELS} a level (the GGX chain, which filters the map's residual, \
         its lights taken out as the renderer's chain does, against that residual's exact \
         prefilter), \
         the technique against Monte Carlo (shading). Source: the \
         analytic sky, its sun ~10⁵ × the zenith, at each width. A conversion by areas \
         \"planned\" gathers each output texel's source texels by weights worked out once \
         for its sizes (`Converter::plan`, in float64 on the host's cores, timed apart): \
         what a map that changes at a fixed size (a frame loop, a set of probes) pays each \
         time; the row above it is one conversion from nothing. No planned row where the \
         plan would not fit the device's largest storage buffer."
    );
    let mut body = String::from(
        "| input | pass | GPU ms | floor ms | ratio | error |\n|---|---|---|---|---|---|\n",
    );
    for r in &rows {
        body.push_str(&format!(
            "| {} | {} | {:.3} | {:.3} | {:.1} | {} |\n",
            r.input,
            r.pass,
            r.ms,
            r.floor,
            r.ms / r.floor,
            r.error
        ));
    }
    Ok(Report {
        job: "floors",
        title: "Every pass against its floor",
        method,
        body,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn spread_texels_cover_small_levels_and_spread_over_large_ones() {
        let check = |s: u32, set: &[(usize, DVec3)]| {
            for &(t, d) in set {
                let t = t as u32;
                let (face, i, j) = (t / (s * s), t % s, (t / s) % s);
                let want = Mapping::Cube.coord_to_dir(Mapping::texel_center(s, s, face, i, j));
                assert!(d.distance(want) < 1e-12, "texel {t} of {s}");
            }
        };
        let small = spread_texels(4, 256);
        assert_eq!(small.len(), 96);
        let mut seen: Vec<usize> = small.iter().map(|p| p.0).collect();
        seen.sort_unstable();
        assert_eq!(seen, (0..96).collect::<Vec<_>>());
        check(4, &small);
        let large = spread_texels(64, 256);
        assert_eq!(large.len(), 256);
        check(64, &large);
        let mut seen: Vec<usize> = large.iter().map(|p| p.0).collect();
        seen.sort_unstable();
        seen.dedup();
        assert!(seen.len() > 250, "{} distinct", seen.len());
        // Every face and every eighth of each axis is visited.
        for part in 0..8 {
            let on =
                |axis: fn(usize) -> usize| large.iter().filter(|p| axis(p.0) / 8 == part).count();
            assert!(on(|t| t % 64) > 16, "columns {part}");
            assert!(on(|t| (t / 64) % 64) > 16, "rows {part}");
        }
        for face in 0..6 {
            assert!(large.iter().filter(|p| p.0 / 4096 == face).count() >= 42);
        }
    }
}
