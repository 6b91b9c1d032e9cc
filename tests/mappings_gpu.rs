//! The GLSL mapping functions against the float64 ones: round trips and texel solid angles.

mod common;

use common::compare::{abs_err, Errors};
use envlight::math::synth::stress_directions;
use envlight::math::Mapping;
use envlight::passes::testing::probe::MappingProbe;
use glam::DVec3;

fn angle(a: DVec3, b: DVec3) -> f64 {
    a.cross(b).length().atan2(a.dot(b))
}

#[test]
fn glsl_round_trip_under_1e5_rad() {
    let ctx = common::ctx();
    {
        let probe = MappingProbe::new(&ctx).unwrap();
        let dirs64 = stress_directions();
        assert!(dirs64.len() >= 100_000);
        let dirs: Vec<[f32; 3]> = dirs64
            .iter()
            .map(|d| [d.x as f32, d.y as f32, d.z as f32])
            .collect();
        for m in Mapping::ALL {
            let out = probe.round_trip(m, &dirs).unwrap();
            let mut worst = Errors::new();
            for (d, r) in dirs.iter().zip(&out) {
                // The f32 input, renormalised in f64, is the truth the GPU must return.
                let d = DVec3::new(d[0] as f64, d[1] as f64, d[2] as f64).normalize();
                let back = DVec3::new(r.dir[0] as f64, r.dir[1] as f64, r.dir[2] as f64);
                assert!(back.is_finite(), "{m:?}: non-finite direction for {d}");
                assert!(
                    (0.0..=1.0).contains(&r.uv[0]) && (0.0..=1.0).contains(&r.uv[1]),
                    "{m:?} {d}: uv {:?}",
                    r.uv
                );
                assert!(r.layer < m.layers());
                // The GPU's face or half must be the f64 one except on exact ties.
                worst.add(angle(d, back.normalize()), d);
            }
            assert!(
                worst.count() == dirs.len() && worst.worst() < 1e-5,
                "{m:?}: worst GLSL round trip {:e} rad at {:?}",
                worst.worst(),
                worst.at()
            );
            eprintln!("{m:?}: worst GLSL round trip {:.2e} rad", worst.worst());
        }
    }
    common::finish(ctx);
}

#[test]
fn glsl_coordinates_match_f64() {
    // Same texture coordinates as the float64 oracle, to f32 precision, away from ties.
    let ctx = common::ctx();
    {
        let probe = MappingProbe::new(&ctx).unwrap();
        let dirs64 = envlight::math::synth::fibonacci_sphere(20_000);
        let dirs: Vec<[f32; 3]> = dirs64
            .iter()
            .map(|d| [d.x as f32, d.y as f32, d.z as f32])
            .collect();
        for m in Mapping::ALL {
            let out = probe.round_trip(m, &dirs).unwrap();
            let mut ties = 0;
            for (d, r) in dirs.iter().zip(&out) {
                let d = DVec3::new(d[0] as f64, d[1] as f64, d[2] as f64).normalize();
                let c = m.dir_to_coord(d);
                if c.layer != r.layer {
                    // Only a direction on a face or half boundary may land on the other side,
                    // decided by the last bit; any other mismatch is a wrong face order.
                    let tie = match m {
                        Mapping::Cube => {
                            let mut a = [d.x.abs(), d.y.abs(), d.z.abs()];
                            a.sort_by(f64::total_cmp);
                            a[2] - a[1] < 1e-6
                        }
                        Mapping::DualParaboloid => d.y.abs() < 1e-6,
                        _ => false,
                    };
                    assert!(
                        tie,
                        "{m:?} {d}: f64 layer {} but GLSL layer {}",
                        c.layer, r.layer
                    );
                    ties += 1;
                    continue;
                }
                let du = (c.u - r.uv[0] as f64).abs();
                let du = du.min(1.0 - du); // the lat-long seam wraps
                let dv = (c.v - r.uv[1] as f64).abs();
                assert!(
                    du < 2e-6 && dv < 2e-6,
                    "{m:?} {d}: f64 ({}, {}) GLSL {:?}",
                    c.u,
                    c.v,
                    r.uv
                );
            }
            // Ties are rare on a Fibonacci sphere: a handful out of 20 000.
            assert!(ties <= 20, "{m:?}: {ties} face or half mismatches");
        }
    }
    common::finish(ctx);
}

#[test]
fn glsl_solid_angles_sum_to_4pi_and_match_f64() {
    let ctx = common::ctx();
    {
        let probe = MappingProbe::new(&ctx).unwrap();
        for m in Mapping::ALL {
            for n in [1u32, 2, 3, 7, 64, 255, 512] {
                let (w, h) = if m == Mapping::LatLong {
                    (2 * n, n)
                } else {
                    (n, n)
                };
                let gpu = probe.solid_angles(m, w, h).unwrap();
                let mut sum = 0.0f64;
                let mut worst = Errors::new();
                for j in 0..h {
                    for i in 0..w {
                        let g = gpu[(j * w + i) as usize] as f64;
                        let f = m.texel_solid_angle(w, h, i, j);
                        assert!(g.is_finite() && g >= 0.0, "{m:?} {w}x{h} ({i},{j}): {g}");
                        sum += g;
                        // Rim texels can hold slivers; compare them against the texel scale.
                        let scale =
                            f.max(4.0 * std::f64::consts::PI / (w * h * m.layers()) as f64 * 1e-2);
                        worst.add(abs_err(g, f, (i, j)) / scale, (i, j, g, f));
                    }
                }
                let total = sum * m.layers() as f64;
                let rel = (total / (4.0 * std::f64::consts::PI) - 1.0).abs();
                assert!(rel < 1e-5, "{m:?} {w}x{h}: GPU sum {total} rel err {rel:e}");
                // Lat-long texels have a closed form: a few float ulps, also at the rows
                // next to the poles and at 512 rows, where a sine accurate only to an absolute
                // 2^-21 (as drivers are allowed, NVIDIA's) would be 1e-4 off. Cube texels take
                // Gauss rules, 8 points each way (3.6e-6 off on a face of one texel), 2 from 64
                // texels a side (within 2e-8 of the exact angle there), over texel edges
                // 2i/n − 1 rounded to float32 (1.5e-5 of a texel's width at n = 255): 5e-5.
                // Disc mappings' rim slivers are integrated numerically: 2e-3 of the texel
                // scale.
                let bound = match m {
                    Mapping::LatLong => 2e-6,
                    Mapping::Cube => 5e-5,
                    _ => 2e-3,
                };
                assert!(
                    worst.worst() < bound,
                    "{m:?} {w}x{h}: worst texel rel err {:e} at {:?}",
                    worst.worst(),
                    worst.at()
                );
            }
        }
    }
    common::finish(ctx);
}
