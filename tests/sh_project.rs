//! The SH projection pass (`passes::sh_project`) against the float64 projection and analytic
//! truths, both reductions, turned maps and real probes.

mod common;
#[path = "twins/sh_project.rs"]
mod twin;

use twin::gpu_project;

use common::worst_vs_cpu;

use envlight::gpu::Timed;
use envlight::math::sh;
use envlight::math::synth::Sky;
use envlight::math::Mapping;
use envlight::passes::sh_project::{ShProjector, Subgroups};
use envlight::EnvMap;
use envlight::GpuEnvMap;
use std::f64::consts::PI;

/// A constant environment L projects to L00 = 2√π·L and nothing else, in every mapping and
/// with both reductions. The texel solid angles sum to 4π to 1e-5 in f32 (tests/mappings_gpu),
/// which bounds L00's error; every other coefficient is ∑ L·∫_texel Y_k, whose exact sum is
/// zero, left with the 2×2 Gauss rule's fourth-order error and f32 rounding.
#[test]
fn constant_environment_projects_to_l00_only() {
    let ctx = common::ctx();
    if !common::require(ctx.info().subgroup_arithmetic, "subgroup arithmetic") {
        return;
    }
    {
        for sg in [Subgroups::Auto, Subgroups::Off] {
            let p = ShProjector::new(&ctx, sg).unwrap();
            // Both reductions run: the subgroups' where allowed, the shared tree otherwise.
            assert_eq!(p.uses_subgroups(), sg == Subgroups::Auto);
            for m in Mapping::ALL {
                // The angular rim, where the density vanishes, needs finer texels for 1e-6.
                let size = if matches!(m, Mapping::LatLong | Mapping::Angular) {
                    128
                } else {
                    48
                };
                let (w, h) = m.extent_for_size(size);
                let l = 1.7f32;
                let map = EnvMap::new(
                    m,
                    w,
                    h,
                    vec![[l, 2.0 * l, 0.5 * l]; (w * h * m.layers()) as usize],
                );
                let c = gpu_project(&ctx, &p, &map, 8);
                let expect = 2.0 * PI.sqrt() * l as f64;
                assert!(
                    (c[0][0] / expect - 1.0).abs() < 1e-5,
                    "{m:?} {sg:?}: L00 {} vs {expect}",
                    c[0][0]
                );
                assert!((c[0][1] / (2.0 * expect) - 1.0).abs() < 1e-5);
                for (k, ck) in c.iter().enumerate().skip(1) {
                    for v in ck {
                        assert!(
                            v.abs() < 1e-6 * 2.0 * expect,
                            "{m:?} {sg:?}: coefficient {k} = {v}"
                        );
                    }
                }
            }
        }
    }
    common::finish(ctx);
}

/// A single band (plus a constant to keep radiance non-negative) projects onto that band. The
/// map holds point values at texel centres, so the f64 projection differs from the analytic
/// coefficients by the texels' piecewise-constant reading of a smooth function: a band-l
/// function varies on the scale 1/l, so the error is about (l·h)²/24 of its amplitude with h
/// the largest texel angle; we allow (l·h)²/12. The GPU must match the f64 projection within
/// 1e-5 of |L00|.
#[test]
fn single_band_projects_onto_that_band() {
    let ctx = common::ctx();
    {
        let p = ShProjector::new(&ctx, Subgroups::Auto).unwrap();
        for (l, m) in [(1u32, 1i32), (2, -2), (3, 0), (5, 4), (8, -7)] {
            let k = sh::index(l, m);
            let f = |d: glam::DVec3| {
                let y = sh::basis(8, d);
                let v = 3.0 + y[k];
                [v, 0.5 * v, 2.0 * v]
            };
            for mapping in [Mapping::Cube, Mapping::LatLong] {
                let (w, h) =
                    mapping.extent_for_size(if mapping == Mapping::Cube { 64 } else { 256 });
                let map = EnvMap::from_fn(mapping, w, h, 1, f);
                let cpu = sh::project(&map, 8);
                let gpu = gpu_project(&ctx, &p, &map, 8);
                let e = worst_vs_cpu(&gpu, &cpu);
                assert!(e < 1e-5, "({l},{m}) {mapping:?}: GPU vs f64 {e:e}");
                let c00 = 3.0 * 2.0 * PI.sqrt();
                let hmax = if mapping == Mapping::Cube {
                    2.0 / w as f64
                } else {
                    2.0 * PI / w as f64
                };
                let tol = (l as f64 * hmax).powi(2) / 12.0;
                for (j, cj) in cpu.iter().enumerate() {
                    let want = if j == k {
                        1.0
                    } else if j == 0 {
                        c00
                    } else {
                        0.0
                    };
                    let scale = if j == 0 { c00 } else { 1.0 };
                    assert!(
                        (cj[0] - want).abs() < tol * scale,
                        "({l},{m}) {mapping:?}: coefficient {j} = {} (want {want}, tol {tol:e})",
                        cj[0]
                    );
                }
            }
        }
    }
    common::finish(ctx);
}

/// The reduction stays accurate in f32 on a 4096×2048 map whose sun is ~1e5 times the sky.
#[test]
fn four_k_sun_map_projects_accurately() {
    let ctx = common::ctx();
    {
        let p = ShProjector::new(&ctx, Subgroups::Auto).unwrap();
        let map = EnvMap::from_fn(Mapping::LatLong, 4096, 2048, 1, |d| {
            Sky::default().radiance(d)
        });
        assert!(map.stats().max_luminance > 1e4);
        let cpu = sh::project(&map, 2);
        let gpu = gpu_project(&ctx, &p, &map, 2);
        let e = worst_vs_cpu(&gpu, &cpu);
        eprintln!("4k sun map, lmax 2: worst |GPU - f64| / |L00| = {e:.2e}");
        assert!(e < 1e-5, "{e:e}");
    }
    common::finish(ctx);
}

/// Every real probe, in its native mapping, halved by 2 × 2 box averages (its suns, rims and
/// seams kept; the 4k test above holds f32 accuracy on a large map), to l = 8: GPU within
/// 1e-5 of |L00| of the f64 projection, and R&H's matrix from the GPU coefficients agrees
/// with the polynomial. The float64 projections (81 basis functions at 4 Gauss points a
/// texel, ~2 s a halved 1k probe) run on every core, a probe each, before the GPU's.
#[test]
fn real_probes_match_the_float64_projection() {
    let Some(dir) = common::probes() else { return };
    let mut specs: Vec<String> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .map(|f| if f.is_dir() { f.join("{face}.hdr") } else { f })
        .map(|f| f.to_string_lossy().to_string())
        .filter(|s| s.ends_with(".hdr") || s.ends_with(".exr") || s.ends_with(".dds"))
        .collect();
    specs.sort();
    assert!(specs.len() >= 20, "only {} probes", specs.len());
    let load = |s: &str| {
        let opts = envlight::io::LoadOptions::default();
        match envlight::io::face_paths(s) {
            Some(paths) => envlight::io::load_cube_faces(&paths, &opts),
            None => envlight::io::load(s, &opts),
        }
        .unwrap()
    };
    let threads = std::thread::available_parallelism().map_or(1, |n| n.get());
    let next = std::sync::atomic::AtomicUsize::new(0);
    let cpu: Vec<(usize, EnvMap, Vec<[f64; 3]>)> = std::thread::scope(|scope| {
        let workers: Vec<_> = (0..threads)
            .map(|_| {
                scope.spawn(|| {
                    let mut done = Vec::new();
                    loop {
                        let k = next.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
                        let Some(s) = specs.get(k) else { break };
                        let map = halved(&load(s));
                        let c = sh::project(&map, 8);
                        done.push((k, map, c));
                    }
                    done
                })
            })
            .collect();
        let mut all: Vec<_> = workers
            .into_iter()
            .flat_map(|w| w.join().unwrap())
            .collect();
        all.sort_by_key(|d| d.0);
        all
    });
    let ctx = common::ctx();
    {
        let p = ShProjector::new(&ctx, Subgroups::Auto).unwrap();
        for (k, map, cpu) in &cpu {
            let s = &specs[*k];
            let gpu = gpu_project(&ctx, &p, map, 8);
            let e = worst_vs_cpu(&gpu, cpu);
            eprintln!("{s}: worst |GPU - f64| / |L00| = {e:.2e}");
            assert!(e < 1e-5, "{s}: {e:e}");
            let coeffs = envlight::passes::sh_project::ShCoefficients {
                lmax: 8,
                coeffs: gpu.clone(),
            };
            let mats = coeffs.irradiance_matrices();
            let e9: Vec<[f64; 3]> = sh::irradiance_coeffs(&gpu[..9]);
            for d in envlight::math::synth::fibonacci_sphere(200) {
                let poly = sh::eval(&e9, d);
                for c in 0..3 {
                    let mat = sh::eval_matrix(&mats[c], d);
                    assert!(
                        (poly[c] - mat).abs() <= 1e-6 * poly[c].abs().max(1e-3 * e9[0][c].abs()),
                        "{s}"
                    );
                }
            }
        }
        assert_eq!(cpu.len(), specs.len());
    }
    common::finish(ctx);
}

/// `map` at half its size in each direction, each texel the mean of the 2 × 2 it covers.
fn halved(map: &EnvMap) -> EnvMap {
    let (w, h) = (map.width / 2, map.height / 2);
    let mut texels = Vec::with_capacity((w * h * map.layers()) as usize);
    for layer in 0..map.layers() {
        for j in 0..h {
            for i in 0..w {
                let at = |di: u32, dj: u32| {
                    map.texels
                        [((layer * map.height + 2 * j + dj) * map.width + 2 * i + di) as usize]
                };
                let q = [at(0, 0), at(1, 0), at(0, 1), at(1, 1)];
                texels.push([0, 1, 2].map(|c| q.iter().map(|t| t[c]).sum::<f32>() / 4.0));
            }
        }
    }
    EnvMap::new(map.mapping, w, h, texels)
}

/// Orientation options rotate the coefficients as documented: the GPU with an orientation
/// matches the f64 projection with the same file → world matrix, and a flip of y negates
/// exactly the coefficients odd in y. On lat-long maps, whose separable projection turns its
/// sums from the map's own polar frame into the world's at the end (a reflection where the
/// file is flipped, or not), every combination of flips and a turn, orders 2 and 8: within
/// 1e-5 of |L00| of the f64 projection.
/// Band 0 alone (what light extraction's threshold reads: `Extractor::record` takes L00) on
/// the per-texel mappings, a sun sky: the float64 projection's L00 within 1e-5 of itself (the
/// same bound as the other bands' tests: f32 sums over a sun 1e5 × the sky), and equal bit for
/// bit to the first coefficient of a band-2 projection of the same map, which sums the same
/// terms in the same order.
#[test]
fn band_zero_matches_the_float64_projection_on_every_mapping() {
    let ctx = common::ctx();
    {
        let p = ShProjector::new(&ctx, Subgroups::Auto).unwrap();
        let sky = Sky::default();
        for (m, size) in [
            (Mapping::Cube, 48),
            (Mapping::Angular, 128),
            (Mapping::DualParaboloid, 64),
        ] {
            let (w, h) = m.extent_for_size(size);
            let map = EnvMap::from_fn(m, w, h, 2, |d| sky.radiance(d));
            let g = GpuEnvMap::upload(&ctx, &map).unwrap();
            let zero = p.run(&g, 0).unwrap().value;
            assert_eq!(zero.coeffs.len(), 1, "{m:?}");
            let cpu = sh::project(&map, 0);
            let e = worst_vs_cpu(&zero.coeffs, &cpu);
            assert!(e < 1e-5, "{m:?}: L00 off by {e:e}");
            let two = p.run(&g, 2).unwrap().value;
            assert_eq!(zero.coeffs[0], two.coeffs[0], "{m:?}");
        }
    }
    common::finish(ctx);
}

#[test]
fn oriented_projection_matches_and_flips_parity() {
    let ctx = common::ctx();
    {
        let p = ShProjector::new(&ctx, Subgroups::Auto).unwrap();
        let map = EnvMap::from_fn(Mapping::Cube, 32, 32, 2, envlight::math::synth::smooth_env);
        let g = GpuEnvMap::upload(&ctx, &map).unwrap();
        let o = envlight::Orientation {
            flip_u: false,
            flip_v: true,
            rotate_y_degrees: 0.0,
        };
        let Timed { value: gpu, .. } = p.run_oriented(&g, 4, &o).unwrap();
        let cpu = sh::project_oriented(&map, 4, o.world_to_file().transpose());
        assert!(worst_vs_cpu(&gpu.coeffs, &cpu) < 1e-5);
        let plain = sh::project(&map, 4);
        // Y_lm is odd in y exactly when m < 0 (it carries sin(|m|φ)).
        for l in 0..=4u32 {
            for m in -(l as i32)..=(l as i32) {
                let k = sh::index(l, m);
                let sign = if m < 0 { -1.0 } else { 1.0 };
                assert!((cpu[k][0] - sign * plain[k][0]).abs() < 1e-12, "({l},{m})");
            }
        }
        let sky = Sky::default();
        let latlong = EnvMap::from_fn(Mapping::LatLong, 256, 128, 2, |d| {
            let s = envlight::math::synth::smooth_env(d);
            let k = sky.radiance(d);
            [s[0] + k[0], s[1] + 0.5 * k[1], s[2]]
        });
        let g = GpuEnvMap::upload(&ctx, &latlong).unwrap();
        for (flip_u, flip_v, rotate_y_degrees) in [
            (false, false, 0.0),
            (true, false, 0.0),
            (false, true, 0.0),
            (true, true, 0.0),
            (false, false, 37.0),
            (true, false, -110.0),
            (false, true, 200.0),
        ] {
            let o = envlight::Orientation {
                flip_u,
                flip_v,
                rotate_y_degrees,
            };
            for lmax in [2, 8] {
                let Timed { value: gpu, .. } = p.run_oriented(&g, lmax, &o).unwrap();
                let cpu = sh::project_oriented(&latlong, lmax, o.world_to_file().transpose());
                let e = worst_vs_cpu(&gpu.coeffs, &cpu);
                eprintln!("lat-long {o:?} order {lmax}: {e:.2e}");
                assert!(e < 1e-5, "lat-long {o:?} order {lmax}: {e:e}");
            }
        }
    }
    common::finish(ctx);
}

/// Both reductions (subgroup arithmetic and the shared-memory tree) on a map that is not
/// constant: a sun ~1e5 times the sky, orders 2 and 8, each against the float64 projection.
/// A reduction that dropped or doubled one workgroup's partial sum would move the
/// coefficients by far more than 1e-5 of L00 (the f32 bound the 4k test measures).
#[test]
fn both_reductions_match_f64_on_a_sun_map() {
    let ctx = common::ctx();
    twin::check(&ctx);
    common::finish(ctx);
}
