//! Light extraction on the GPU: the lights pass against its float64 twin
//! (`math::lights::light_sum`), turned, on lat-long and angular maps, with the cosine and
//! GGX; and the split's exactness: the exact filter of a map is the residual's plus the light
//! sum, so extracting lights loses nothing the exact filter sees.

mod common;
#[path = "twins/lights.rs"]
mod twin;

use twin::sky;

use common::compare::Errors;
use envlight::math::exact::ExactFilter;
use envlight::math::lights::{
    cluster_irradiance, clusters, diffuse_options, extract, light_sum, prepare, ExtractOptions,
    LightKernel, CLUSTER_GRID, DIFFUSE_RATIO,
};
use envlight::math::split_sum::chain_norm;
use envlight::math::synth::Sky;
use envlight::math::{Coord, Mapping, Orientation};
use envlight::EnvMap;
use glam::DVec3;

/// Every texel of a 16² cube level (and an 8² one) against the twin, for the cosine and GGX
/// α 0.02 (a lobe far narrower than the 64-wide maps' texels: every node counts) and 0.3, the
/// map turned 30° and mirrored. Bound 1e-5 of the level's largest texel: float32 sums of a few
/// hundred terms (measured: printed).
#[test]
fn lights_pass_matches_its_float64_twin() {
    let ctx = common::ctx();
    twin::check(&ctx);
    common::finish(ctx);
}

/// The exact filter of the map equals the residual's plus the light sum over ∫K (both float64):
/// the split is exact, and the light sum's quadrature (2 × 2 Gauss cells per lobe width at
/// the finest α) integrates the light texels as the exact filter's adaptive cells do. At the
/// sun, beside it and 53° from it, α 0.02 to 1, on a 512 × 256 sky whose sun is 5·10⁴ × the
/// zenith (96 light texels): bound 1e-4 of the filtered value (measured: printed). The same
/// with the local rule (`prepare_local`: each texel only as many cells as the kernel's scale
/// at it asks, a bake's lights), whose sum equals `light_sum_local`'s (the extraction twin's
/// rule) to rounding.
#[test]
fn extraction_keeps_the_exact_filter() {
    let map = sky(Mapping::LatLong, 512);
    let ex = extract(&map, &ExtractOptions::default());
    let fixed = prepare(&map, &ex, glam::DMat3::IDENTITY, 0.02);
    let local = envlight::math::lights::prepare_local(
        &map,
        &ex.lights,
        glam::DMat3::IDENTITY,
        envlight::math::lights::cells_for(&ex, 0.02),
    );
    keeps_the_exact_filter(&map, &ex, &fixed, "fixed");
    keeps_the_exact_filter(&map, &ex, &local, "local");
}

fn keeps_the_exact_filter(
    map: &EnvMap,
    ex: &envlight::math::lights::Extraction,
    prepared: &[envlight::math::lights::PreparedLight],
    rule: &str,
) {
    let sun = Sky::default().sun_dir;
    let full = ExactFilter::new(map, glam::DMat3::IDENTITY);
    let res = ExactFilter::new(&ex.residual, glam::DMat3::IDENTITY);
    for alpha in [0.02, 0.1, 0.4, 1.0] {
        let dirs = [
            sun,
            (sun + DVec3::new(0.0, 0.05, 0.0)).normalize(),
            (0.6 * sun + 0.8 * sun.cross(DVec3::Y).normalize()).normalize(),
        ];
        for r in dirs {
            let want = full.ggx(r, alpha);
            let split = res.ggx(r, alpha);
            let kernel = LightKernel::Ggx { alpha };
            let l = light_sum(prepared, r, kernel);
            let n = chain_norm(alpha);
            if rule == "local" {
                let twin = envlight::math::lights::light_sum_local(
                    map,
                    ex,
                    glam::DMat3::IDENTITY,
                    r,
                    kernel,
                );
                for c in 0..3 {
                    let e = (l[c] - twin[c]).abs() / twin[c];
                    assert!(e < 1e-12, "{rule} α {alpha} r {r}: {} vs {}", l[c], twin[c]);
                }
            }
            for c in 0..3 {
                let got = split[c] + l[c] / n;
                let e = (got - want[c]).abs() / want[c];
                if c == 1 {
                    eprintln!("{rule}: α {alpha} r {r:.3}: {e:.1e}");
                }
                assert!(e < 1e-4, "{rule} α {alpha} r {r}: {got} vs {}", want[c]);
            }
        }
    }
}

/// What extraction buys SH irradiance: a white diffuse sphere (32², orthographic) by SH
/// order 2 with lights extracted (the default: diffuse techniques extract above 2 × the mean
/// luminance and sum the texels by clusters) and without, against the Monte Carlo reference
/// at 16384 samples per pixel (its noise, from a quarter of the samples, 0.4–0.6%), on
/// spiaggia_di_mondello (sun), quarry_01 (sun) and studio_small_08 (softboxes; also at a
/// shallower diffuse extraction, above 32 × the mean). Measured relative RMS over the
/// sphere, lights / none: spiaggia 0.55% / 4.37%, quarry 0.55% / 4.26%, studio_small_08
/// 0.97% / 4.16%, and 3.22% extracting above 32 × the mean (0.62%, 0.81% and 4.07% with the
/// FIS texels' extraction, above 32 × the mean and at most 256 texels, before clusters).
/// Bounds at 1.3×.
#[test]
fn sh_irradiance_with_lights_against_mc_on_real_probes() {
    use common::scenes::{object, scene, sphere_camera, sphere_pixels, unit_sphere};
    use envlight::math::brdf::Brdf;
    use envlight::render::Renderer;
    use envlight::scene::{LightsMode, Technique};
    let Some(dir) = common::probes() else {
        return;
    };
    let ctx = common::ctx();
    {
        let cam = sphere_camera(32);
        let renderer = Renderer::new(&ctx);
        let pixels = sphere_pixels(&cam);
        let rel_rms = |a: &EnvMap, b: &EnvMap| common::scenes::rel_rms(a, b, &pixels);
        // (probe, diffuse light ratio, bound with lights, bound without)
        let cases = [
            ("spiaggia_di_mondello_1k.hdr", None, 0.0072, 0.0568),
            ("quarry_01_1k.hdr", None, 0.0072, 0.0554),
            ("studio_small_08_1k.hdr", None, 0.0126, 0.0541),
            ("studio_small_08_1k.hdr", Some(32.0), 0.0419, 0.0541),
        ];
        let mut failures = Vec::new();
        for (file, extraction, with, without) in cases {
            let env =
                envlight::io::load(dir.join(file), &envlight::io::LoadOptions::default()).unwrap();
            let sc = |t: Technique, lights: LightsMode| {
                let mut s = scene(
                    cam,
                    vec![object(unit_sphere(), Brdf::Lambert, [1.0; 3], t)],
                    false,
                    64,
                );
                s.environment.lights = lights;
                s.environment.diffuse_light_ratio = extraction;
                s
            };
            let mc_at = |samples| {
                renderer
                    .render(
                        &sc(
                            Technique::Mc {
                                samples,
                                error: None,
                            },
                            LightsMode::None,
                        ),
                        &env,
                    )
                    .unwrap()
            };
            let mc = mc_at(16384);
            // MC's noise: a quarter of the samples differs from it by √(1 + 1/4) of its own.
            let noise = rel_rms(&mc_at(4096).frame, &mc.frame) / 1.25f64.sqrt() / 2.0;
            for (lights, bound) in [(LightsMode::Extract, with), (LightsMode::None, without)] {
                let r = renderer
                    .render(&sc(Technique::Sh { order: 2 }, lights), &env)
                    .unwrap();
                let rms = rel_rms(&r.frame, &mc.frame);
                eprintln!(
                    "{file} SH 2, lights {lights:?} (diffuse ratio {extraction:?}): {:.2}% against MC 16384 (its noise {:.2}%)",
                    100.0 * rms,
                    100.0 * noise
                );
                if rms >= bound {
                    failures.push(format!("{file} {lights:?}: {rms:e}"));
                }
            }
        }
        assert!(failures.is_empty(), "{failures:?}");
    }
    common::finish(ctx);
}

/// What extraction buys FIS: a white GGX sphere (32², orthographic, α 0.1, 0.3, 0.6) by FIS
/// with 64 samples, lights extracted (the default) and not, against Monte Carlo at 16384
/// samples per pixel, on spiaggia_di_mondello and quarry_01 (suns). Measured relative RMS
/// over the sphere, lights / none: spiaggia 0.72% / 21.2%, 0.76% / 13.9%, 0.88% / 15.4%;
/// quarry 0.82% / 24.7%, 0.95% / 17.5%, 1.40% / 22.9% (α 0.1, 0.3, 0.6). Bounds at 1.3×.
#[test]
fn fis_with_lights_against_mc_on_real_probes() {
    use common::scenes::{object, scene, sphere_camera, sphere_pixels, unit_sphere};
    use envlight::math::brdf::Brdf;
    use envlight::render::Renderer;
    use envlight::scene::{LightsMode, Technique};
    let Some(dir) = common::probes() else {
        return;
    };
    let ctx = common::ctx();
    {
        let cam = sphere_camera(32);
        let renderer = Renderer::new(&ctx);
        let pixels = sphere_pixels(&cam);
        let rel_rms = |a: &EnvMap, b: &EnvMap| common::scenes::rel_rms(a, b, &pixels);
        // (probe, [(α, bound with lights, bound without)])
        let cases = [
            (
                "spiaggia_di_mondello_1k.hdr",
                [
                    (0.1, 0.0094, 0.276),
                    (0.3, 0.0099, 0.180),
                    (0.6, 0.0115, 0.200),
                ],
            ),
            (
                "quarry_01_1k.hdr",
                [
                    (0.1, 0.0107, 0.321),
                    (0.3, 0.0124, 0.227),
                    (0.6, 0.0182, 0.297),
                ],
            ),
        ];
        let mut failures = Vec::new();
        for (file, alphas) in cases {
            let env =
                envlight::io::load(dir.join(file), &envlight::io::LoadOptions::default()).unwrap();
            for (alpha, with, without) in alphas {
                let b = Brdf::Ggx {
                    alpha,
                    correlated: true,
                };
                let sc = |t: Technique, lights: LightsMode| {
                    let mut s = scene(cam, vec![object(unit_sphere(), b, [1.0; 3], t)], false, 256);
                    s.environment.lights = lights;
                    s
                };
                let mc = renderer
                    .render(
                        &sc(
                            Technique::Mc {
                                samples: 16384,
                                error: None,
                            },
                            LightsMode::None,
                        ),
                        &env,
                    )
                    .unwrap();
                for (lights, bound) in [(LightsMode::Extract, with), (LightsMode::None, without)] {
                    let t = Technique::Fis {
                        samples: 64,
                        bias: None,
                        rotate: false,
                    };
                    let r = renderer.render(&sc(t, lights), &env).unwrap();
                    let rms = rel_rms(&r.frame, &mc.frame);
                    eprintln!(
                        "{file} GGX α {alpha} FIS 64, lights {lights:?}: {:.2}% against MC 16384",
                        100.0 * rms
                    );
                    if rms >= bound {
                        failures.push(format!("{file} α {alpha} {lights:?}: {rms:e}"));
                    }
                }
            }
        }
        assert!(failures.is_empty(), "{failures:?}");
    }
    common::finish(ctx);
}

/// Light texels cast shadows: a sphere over a white diffuse floor under the sky whose sun is
/// 5·10⁴ × the zenith, `shadows = true`, the floor by FIS (64 samples) with lights extracted,
/// against Monte Carlo with visibility (4096 samples). Each light texel's shadow ray keeps
/// the sun off the floor in the sphere's shadow. Floor pixels deep in that shadow (the sun
/// disc blocked to twice its radius) are compared: measured 10.1% relative RMS (the same
/// against 16384 samples: FIS's own error, lod-blurred residual read past its shadow rays),
/// bound 1.3×. With `lights = "none"` the same pixels err by 957%: the MIP chain's blurred sun
/// leaks into the shadow wherever a sample's own ray is clear.
#[test]
fn light_texels_cast_shadows() {
    use common::scenes::{object, scene};
    use envlight::math::brdf::Brdf;
    use envlight::math::camera::{trace, Camera, Projection, Shape};
    use envlight::render::Renderer;
    use envlight::scene::Technique;
    let ctx = common::ctx();
    {
        let sky = Sky::default();
        let env = EnvMap::from_fn(Mapping::LatLong, 256, 128, 2, move |d| sky.radiance(d));
        let cam = Camera {
            projection: Projection::Orthographic { height: 6.0 },
            eye: [0.0, 8.0, 0.1],
            target: [0.0, 0.0, 0.0],
            up: [0.0, 0.0, -1.0],
            width: 32,
            height: 32,
        };
        let ball = Shape::Sphere {
            center: [0.0, 1.2, 0.0],
            radius: 1.0,
        };
        let floor = Shape::Plane {
            normal: [0.0, 1.0, 0.0],
            offset: 0.0,
            extent: 0.0,
        };
        let sc = |t: Technique| {
            scene(
                cam,
                vec![
                    object(ball, Brdf::Lambert, [0.5; 3], t),
                    object(floor, Brdf::Lambert, [1.0; 3], t),
                ],
                true,
                128,
            )
        };
        let renderer = Renderer::new(&ctx);
        let fis = renderer
            .render(
                &sc(Technique::Fis {
                    samples: 64,
                    bias: None,
                    rotate: false,
                }),
                &env,
            )
            .unwrap();
        let mc = renderer
            .render(
                &sc(Technique::Mc {
                    samples: 4096,
                    error: None,
                }),
                &env,
            )
            .unwrap();
        // Floor pixels whose point sees no sun: the sphere blocks the sun's direction.
        let sun = Sky::default().sun_dir;
        let (mut se, mut sw, mut n) = (0.0, 0.0, 0);
        for j in 0..cam.height {
            for i in 0..cam.width {
                let (o, d) = cam.ray(i, j);
                let Some(hit) = trace(&[ball, floor], o, d) else {
                    continue;
                };
                if hit.index != 1 {
                    continue;
                }
                let p = o + d * hit.t + hit.normal * 1e-4;
                // Deep in the shadow: the whole sun disc (twice its radius) is blocked.
                let (u, w) = envlight::math::brdf::basis(sun);
                let r = 2.0 * Sky::default().sun_radius;
                let blocked = [
                    sun,
                    (sun + r * u).normalize(),
                    (sun - r * u).normalize(),
                    (sun + r * w).normalize(),
                    (sun - r * w).normalize(),
                ]
                .iter()
                .all(|&s| trace(&[ball], p, s).is_some());
                if !blocked {
                    continue;
                }
                let k = (j * cam.width + i) as usize;
                for c in 0..3 {
                    let (x, m) = (fis.frame.texels[k][c] as f64, mc.frame.texels[k][c] as f64);
                    se += (x - m).powi(2);
                    sw += m * m;
                }
                n += 1;
            }
        }
        let rms = (se / sw).sqrt();
        eprintln!(
            "{n} floor pixels in the sun's shadow: FIS + lights vs MC {:.2}%",
            100.0 * rms
        );
        assert!(n > 10, "{n}");
        assert!(rms < 0.132, "{rms}");
    }
    common::finish(ctx);
}

/// A lobe too narrow for the light texels' quadrature (Phong n = 10⁶ by FIS, whose lobe is a
/// tenth of a 256-wide map's texel) on the sun sky: the render reads the whole map instead
/// (`math::lights::resolves`), so it equals the `lights = "none"` render bit for bit, finite.
#[test]
fn lobes_too_narrow_for_the_light_texels_read_the_whole_map() {
    use common::scenes::{object, scene, sphere_camera, unit_sphere};
    use envlight::math::brdf::Brdf;
    use envlight::render::Renderer;
    use envlight::scene::{LightsMode, Technique};
    let ctx = common::ctx();
    {
        let env = sky(Mapping::LatLong, 256);
        let ex = extract(&env, &ExtractOptions::chain());
        assert!(!envlight::math::lights::resolves(&ex, 1e-3));
        let renderer = Renderer::new(&ctx);
        let frames: Vec<EnvMap> = [LightsMode::Extract, LightsMode::None]
            .into_iter()
            .map(|lights| {
                let mut s = scene(
                    sphere_camera(16),
                    vec![object(
                        unit_sphere(),
                        Brdf::Phong { n: 1e6 },
                        [1.0; 3],
                        Technique::Fis {
                            samples: 16,
                            bias: None,
                            rotate: false,
                        },
                    )],
                    false,
                    128,
                );
                s.environment.lights = lights;
                renderer.render(&s, &env).unwrap().frame
            })
            .collect();
        assert!(frames[0].texels.iter().flatten().all(|v| v.is_finite()));
        assert_eq!(frames[0].texels, frames[1].texels);
    }
    common::finish(ctx);
}

/// A prefiltered diffuse sphere with lights extracted against its float64 twin: the diffuse
/// residual's irradiance map (the brute-force rule's twin, `math::filter::Prepared`, at each
/// texel's centre of a 32 × 16 lat-long), read bilinearly as `shade.frag` reads it, plus the
/// light clusters' irradiance (`cluster_irradiance`), over π; on the sky whose sun is
/// 5·10⁴ × the zenith. Bound 1e-4 relative: the brute pass agrees with its twin to 1e-4
/// (tests/brute.rs); measured 1.3e-5 before clusters. Without extraction
/// the sunlit side must differ (the map then blurs the sun over its texels), so the lights
/// are really added.
#[test]
fn prefiltered_irradiance_with_lights_matches_its_float64_twin() {
    use common::scenes::{object, scene, sphere_camera, sphere_pixels, unit_sphere};
    use envlight::math::brdf::Brdf;
    use envlight::math::filter::Kernel;
    use envlight::render::render;
    use envlight::scene::{LightsMode, Technique};
    let ctx = common::ctx();
    {
        let map = sky(Mapping::LatLong, 64);
        let f2w = Orientation::default().world_to_file().transpose();
        let ex = extract(&map, &diffuse_options(DIFFUSE_RATIO));
        let cl = clusters(&ex, f2w, CLUSTER_GRID);
        assert!(!cl.is_empty());
        let (w, h) = (32u32, 16u32);
        let irr = prefiltered_twin(&ex.residual, f2w, Kernel::Cosine, w, h);
        let lookup = |d: DVec3| prefiltered_lookup(&irr, w, h, d);
        let cam = sphere_camera(24);
        let frame = |lights| {
            let mut sc = scene(
                cam,
                vec![object(
                    unit_sphere(),
                    Brdf::Lambert,
                    [1.0; 3],
                    Technique::Prefiltered { size: w },
                )],
                false,
                64,
            );
            sc.environment.lights = lights;
            render(&ctx, &sc, &map).unwrap().frame
        };
        let (with, without) = (frame(LightsMode::Extract), frame(LightsMode::None));
        let (mut errors, mut compared, mut sunlit) = (Errors::new(), 0, 0);
        for (k, n, _) in sphere_pixels(&cam) {
            let e = lookup(n);
            let l = cluster_irradiance(&cl, n);
            for ch in 0..3 {
                let want = (e[ch] + l[ch]) / std::f64::consts::PI;
                errors.rel(with.texels[k][ch], want, 0.0, (k, ch));
            }
            if l[1] > 0.1 * e[1] {
                sunlit += 1;
            }
            compared += 1;
        }
        let moved = with
            .texels
            .iter()
            .zip(&without.texels)
            .filter(|(a, b)| (a[1] - b[1]).abs() > 1e-3 * b[1])
            .count();
        let worst = errors.worst();
        eprintln!("{compared} pixels within {worst:.1e} ({sunlit} sunlit); {moved} differ from lights = none");
        assert!(worst < 1e-4, "{worst:e} at {:?}", errors.at());
        assert!(
            compared > 300 && sunlit > 50 && moved > 100,
            "{compared} {sunlit} {moved}"
        );
    }
    common::finish(ctx);
}

/// The float64 twin of the brute-force pass's `w` × `h` lat-long map of `map` under `kernel`
/// (`math::filter::Prepared`, at each texel's centre).
fn prefiltered_twin(
    map: &EnvMap,
    f2w: glam::DMat3,
    kernel: envlight::math::filter::Kernel,
    w: u32,
    h: u32,
) -> Vec<[f64; 3]> {
    let prepared = envlight::math::filter::Prepared::new(map, f2w);
    (0..w * h)
        .map(|k| {
            let c = Coord {
                layer: 0,
                u: ((k % w) as f64 + 0.5) / w as f64,
                v: ((k / w) as f64 + 0.5) / h as f64,
            };
            prepared.convolve(kernel, Mapping::LatLong.coord_to_dir(c))
        })
        .collect()
}

/// shade.frag's prefiltered_lookup: bilinear, wrapped across u, clamped in v.
fn prefiltered_lookup(map: &[[f64; 3]], w: u32, h: u32, d: DVec3) -> [f64; 3] {
    let c = Mapping::LatLong.dir_to_coord(d);
    let (px, py) = (c.u * w as f64 - 0.5, c.v * h as f64 - 0.5);
    let (i0, j0) = (px.floor() as i64, py.floor() as i64);
    let (tx, ty) = (px - i0 as f64, py - j0 as f64);
    let mut acc = [0.0; 3];
    for k in 0..4 {
        let (di, dj) = (k & 1, k >> 1);
        let i = (i0 + di).rem_euclid(w as i64);
        let j = (j0 + dj).clamp(0, h as i64 - 1);
        let wt = if di == 1 { tx } else { 1.0 - tx } * if dj == 1 { ty } else { 1.0 - ty };
        let t = map[(j * w as i64 + i) as usize];
        for ch in 0..3 {
            acc[ch] += wt * t[ch];
        }
    }
    acc
}

/// A prefiltered Phong sphere with lights extracted against its float64 twin: the chain
/// extraction's (filled) residual prefiltered by the brute-force rule's twin into a 32 × 16
/// lat-long, read bilinearly, plus the light texels under the Phong BRDF through their tree
/// (`LightTree::sum_brdf`, the FIS materials' rule: horizon clipped, the tree's budget a
/// share of the map's value); on the sky whose sun is 5·10⁴ × the zenith, n 8 and 100.
/// Bound 1e-4 relative, as for the diffuse map (the brute pass agrees with its twin to 1e-4;
/// measured: printed). The sun must light some pixels mostly, and the render must differ
/// from `lights = "none"` there. A lobe too narrow for the light texels' nodes (n = 5000 on
/// this 64 × 32 map) reads the whole map's Phong map: identical to `lights = "none"`.
#[test]
fn prefiltered_phong_with_lights_matches_its_float64_twin() {
    use common::scenes::{object, scene, sphere_camera, sphere_pixels, unit_sphere};
    use envlight::math::brdf::Brdf;
    use envlight::math::filter::Kernel;
    use envlight::math::light_tree::LightTree;
    use envlight::math::lights::lobe_scale;
    use envlight::render::Renderer;
    use envlight::scene::{LightsMode, Technique};
    let ctx = common::ctx();
    {
        let map = sky(Mapping::LatLong, 64);
        let f2w = Orientation::default().world_to_file().transpose();
        let ex = extract(&map, &ExtractOptions::chain());
        assert!(!ex.lights.is_empty());
        let (w, h) = (32u32, 16u32);
        let cam = sphere_camera(24);
        let renderer = Renderer::new(&ctx);
        let frame = |n: f64, lights| {
            let mut sc = scene(
                cam,
                vec![object(
                    unit_sphere(),
                    Brdf::Phong { n },
                    [1.0; 3],
                    Technique::Prefiltered { size: w },
                )],
                false,
                64,
            );
            sc.environment.lights = lights;
            renderer.render(&sc, &map).unwrap().frame
        };
        for n in [8.0, 100.0] {
            let brdf = Brdf::Phong { n };
            let scale = lobe_scale(&brdf).unwrap();
            let pre = prefiltered_twin(&ex.residual, f2w, Kernel::Phong { n }, w, h);
            let tree = LightTree::new(prepare(&map, &ex, f2w, scale));
            let (with, without) = (frame(n, LightsMode::Extract), frame(n, LightsMode::None));
            let (mut errors, mut sunlit, mut moved) = (Errors::new(), 0, 0);
            let pixels = sphere_pixels(&cam);
            for &(k, normal, d) in &pixels {
                let v = -d;
                let r = 2.0 * normal.dot(v) * normal - v;
                let m = prefiltered_lookup(&pre, w, h, r);
                let l = tree.sum_brdf(
                    &brdf,
                    normal,
                    v,
                    scale,
                    envlight::math::envmap::luminance(m),
                );
                for ch in 0..3 {
                    let want = m[ch] + l[ch];
                    errors.rel(with.texels[k][ch], want, 0.0, (k, ch));
                }
                if l[1] > m[1] {
                    sunlit += 1;
                    if (with.texels[k][1] - without.texels[k][1]).abs()
                        > 1e-2 * without.texels[k][1]
                    {
                        moved += 1;
                    }
                }
            }
            let worst = errors.worst();
            eprintln!("n {n}: {} pixels within {worst:.1e}; {sunlit} lit mostly by the sun, {moved} of them differ from lights = none", pixels.len());
            assert!(worst < 1e-4, "n {n}: {worst:e} at {:?}", errors.at());
            assert!(sunlit > 5 && moved > 5, "n {n}: {sunlit} {moved}");
        }
        // Too narrow for the nodes (not for the brute force): the whole map, as without
        // lights.
        let narrow = 5000.0;
        let scale = lobe_scale(&Brdf::Phong { n: narrow }).unwrap();
        assert!(!envlight::math::lights::resolves(&ex, scale));
        assert_eq!(
            frame(narrow, LightsMode::Extract).texels,
            frame(narrow, LightsMode::None).texels
        );
    }
    common::finish(ctx);
}

/// Simulate only what the scene calls for: with lights extracted, SH objects' coefficients
/// are the whole map's less the light texels' (`math::lights::light_sh`, on the CPU), so the
/// map is projected once, with or without lights, and also where an SH-BRDF object (which does
/// not use the lights) reads the whole map's.
#[test]
fn sh_projects_the_map_once_with_or_without_lights() {
    use common::scenes::{object, scene, sphere_camera, unit_sphere};
    use envlight::math::brdf::Brdf;
    use envlight::math::camera::Shape;
    use envlight::render::render;
    use envlight::render::PassKind;
    use envlight::scene::{LightsMode, Technique};
    let ctx = common::ctx();
    {
        let map = sky(Mapping::LatLong, 64);
        assert!(!extract(&map, &ExtractOptions::default()).lights.is_empty());
        let sh = object(
            unit_sphere(),
            Brdf::Lambert,
            [1.0; 3],
            Technique::Sh { order: 2 },
        );
        let other = Shape::Sphere {
            center: [2.5, 0.0, 0.0],
            radius: 1.0,
        };
        let sh_brdf = object(
            other,
            Brdf::Phong { n: 8.0 },
            [1.0; 3],
            Technique::ShBrdf {
                order: 2,
                grid: 4,
                window: None,
            },
        );
        let projections = |objects, lights| {
            let mut sc = scene(sphere_camera(8), objects, false, 16);
            sc.environment.lights = lights;
            let r = render(&ctx, &sc, &map).unwrap();
            r.records
                .iter()
                .filter(|p| p.kind == PassKind::ShProjection)
                .count()
        };
        assert_eq!(projections(vec![sh.clone()], LightsMode::Extract), 1);
        assert_eq!(projections(vec![sh.clone()], LightsMode::None), 1);
        assert_eq!(projections(vec![sh, sh_brdf], LightsMode::Extract), 1);
    }
    common::finish(ctx);
}
