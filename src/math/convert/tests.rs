//! The unit tests of `convert` (a file of their own: the module stays readable).

use super::*;

/// The worst channel's relative difference between the powers of `out` and `src`.
fn power_error(out: &EnvMap, src: &EnvMap) -> f64 {
    let (p, q) = (out.power(), src.power());
    (0..3)
        .map(|c| (p[c] / q[c] - 1.0).abs())
        .fold(0.0, f64::max)
}

/// The fast path's split: the list holds exactly the texels `area_general_texel` names,
/// and every texel with a corner nearer the pole's axis than POLE_NEAR / size (where the
/// general walk takes more points, and where a pole can lie on or inside the polygon) is
/// among them, upright and upside down, at even and odd sizes from the smallest fast one;
/// on a paraboloid also every texel with a corner outside its disc (whose polygon the
/// general walk clips to the half).
#[test]
fn fast_path_leaves_every_texel_near_a_pole_to_the_general_walk() {
    use crate::math::Orientation;
    for (face, y) in area::POLE_FACES.iter().zip([1.0, -1.0]) {
        let c = Coord {
            layer: *face,
            u: 0.5,
            v: 0.5,
        };
        assert!((Mapping::Cube.coord_to_dir(c) - DVec3::new(0.0, y, 0.0)).length() < 1e-12);
    }
    for to in [Mapping::Cube, Mapping::DualParaboloid] {
        for n in (area::FAST_MIN_SIZE - 2..area::FAST_MIN_SIZE + 40).chain([255, 256, 1000]) {
            check_split(to, n);
            for flip_v in [false, true] {
                let o = Orientation {
                    flip_u: false,
                    flip_v,
                    rotate_y_degrees: 29.0,
                };
                check_near_poles(to, n, o.world_to_file());
            }
        }
    }
}

/// The fast path's arctangent (glsl/include/convert_area.glsl's `atan_near`) holds within 45°
/// of its reference, the edge of the column under a texel's first corner: every point the
/// fast path takes (its edges' points and their curves' midpoints, at up to
/// `area::POLE_STEPS` chords) turns from that corner by at most 45° less a column of the
/// narrowest source it serves (`area::FAST_MIN_SOURCE_WIDTH`), at every fast texel of each
/// size from the smallest fast one. Measured: 10.6° at most, under the 33.75° allowed.
#[test]
fn fast_texels_turn_within_their_arctangents_reach() {
    let allowed = 45.0 - 360.0 / area::FAST_MIN_SOURCE_WIDTH as f64;
    let mut worst = 0.0f64;
    for to in [Mapping::Cube, Mapping::DualParaboloid] {
        for n in (area::FAST_MIN_SIZE..area::FAST_MIN_SIZE + 24).chain([97, 256]) {
            let m = 2 * area::POLE_STEPS;
            for layer in 0..to.layers() {
                for j in 0..n {
                    for i in 0..n {
                        if area_general_texel(to, layer, i, j, n) {
                            continue;
                        }
                        let dir = |a: u32, b: u32| {
                            to.coord_to_dir(Coord {
                                layer,
                                u: a as f64 / (n * m) as f64,
                                v: b as f64 / (n * m) as f64,
                            })
                        };
                        let first = dir(i * m, j * m);
                        let phi0 = first.x.atan2(-first.z);
                        for q in 0..=m {
                            for (a, b) in [(q, 0), (q, m), (0, q), (m, q)] {
                                let d = dir(i * m + a, j * m + b);
                                let turn = (d.x.atan2(-d.z) - phi0 + PI)
                                    .rem_euclid(std::f64::consts::TAU)
                                    - PI;
                                worst = worst.max(turn.abs().to_degrees());
                            }
                        }
                    }
                }
            }
        }
    }
    eprintln!("fast texels turn by at most {worst:.2}° (allowed {allowed}°)");
    assert!(worst <= allowed, "{worst}° > {allowed}°");
}

/// The list is what `area_general_texel` names, less a paraboloid's texels outside its disc;
/// on a paraboloid the texels with a corner outside the disc are general; from the smallest
/// fast size some texels are not.
fn check_split(to: Mapping, n: u32) {
    let list = area_general_texels(to, n);
    let mut all = Vec::new();
    let mut fast = 0;
    for layer in 0..to.layers() {
        for j in 0..n {
            for i in 0..n {
                let general = area_general_texel(to, layer, i, j, n);
                // The list leaves out a paraboloid's texels outside its disc (the fast
                // dispatch copies a rim texel into them).
                if general && to.texel_in_domain(n, n, i, j) {
                    all.push([i, j, layer, 0]);
                } else if !general {
                    fast += 1;
                }
                if to == Mapping::DualParaboloid {
                    let out = [(0, 0), (1, 0), (1, 1), (0, 1)].iter().any(|&(a, b)| {
                        let s = 2.0 * (i + a) as f64 / n as f64 - 1.0;
                        let t = 2.0 * (j + b) as f64 / n as f64 - 1.0;
                        s * s + t * t > 1.0 + 1e-12
                    });
                    assert!(!out || general, "{to:?} {n}: ({layer}, {i}, {j}) is cut");
                }
            }
        }
    }
    assert_eq!(list, all, "{to:?} size {n}");
    assert_eq!(fast > 0, n >= area::FAST_MIN_SIZE, "{to:?} size {n}");
}

/// Every texel of `to` at side `n` with a corner near a pole's axis, the file turned by
/// `world_to_file`, is general.
fn check_near_poles(to: Mapping, n: u32, world_to_file: DMat3) {
    let near = |layer: u32, a: u32, b: u32| {
        let c = Coord {
            layer,
            u: a as f64 / n as f64,
            v: b as f64 / n as f64,
        };
        let d = world_to_file * to.coord_to_dir(c);
        // The GLSL tests in float32: a margin of 1e-3 of the radius covers it.
        d.x.hypot(d.z) < area::POLE_NEAR / n as f64 * (1.0 + 1e-3)
    };
    let mut nears = 0;
    for layer in 0..to.layers() {
        for j in 0..n {
            for i in 0..n {
                let any = [(0, 0), (1, 0), (1, 1), (0, 1)]
                    .iter()
                    .any(|&(a, b)| near(layer, i + a, j + b));
                if any {
                    nears += 1;
                    assert!(
                        area_general_texel(to, layer, i, j, n),
                        "{to:?} size {n} {layer} {i} {j}"
                    );
                }
            }
        }
    }
    assert!(nears > 0, "{to:?} size {n}: no texel near a pole");
}

/// The halving keeps the power of a map with suns 10⁵ × the sky on both polar rows, the
/// seam and mid-sky (to 1e-6: one float32 rounding per texel; measured 6.6e-9), and
/// each coarse texel is the solid-angle mean of its four, the float64 sum over the fine
/// texels' own solid angles (within 2e-7 relative: the float32 store). Then the paraboloid
/// of the halved map keeps the fine map's power as the fine map's own does (1e-5, the rim
/// edges' chords and the slivers' parabolas; measured 3.0e-6).
#[test]
fn halving_keeps_power_and_means() {
    let (w, h) = (256u32, 128u32);
    let mut m = EnvMap::from_fn(Mapping::LatLong, w, h, 1, |d| {
        [
            1.0 + 0.5 * (13.0 * d.x + 7.0 * d.y).sin(),
            0.7 + 0.3 * d.y,
            1.0,
        ]
    });
    for (i, j) in [
        (0, 0),
        (w / 2 + 1, 0),
        (0, h / 2),
        (w - 1, h / 3),
        (w / 3, h - 1),
    ] {
        m.texels[(j * w + i) as usize] = [1e5, 2e5, 5e4];
    }
    let half = latlong_halved(&m);
    assert_eq!((half.width, half.height), (w / 2, h / 2));
    let e = power_error(&half, &m);
    eprintln!("halved: power error {e:.2e}");
    assert!(e <= 1e-6, "{e:e}");
    let mut sums = vec![([0.0f64; 3], 0.0f64); (w * h / 4) as usize];
    m.for_each_texel(|_, i, j, t, o| {
        let s = &mut sums[((j / 2) * (w / 2) + i / 2) as usize];
        for (acc, x) in s.0.iter_mut().zip(t) {
            *acc += f64::from(x) * o;
        }
        s.1 += o;
    });
    for (k, (sum, o)) in sums.iter().enumerate() {
        for (&x, got) in sum.iter().zip(half.texels[k]) {
            let (want, got) = (x / o, f64::from(got));
            assert!(
                (got - want).abs() <= 2e-7 * want.abs(),
                "texel {k}: {got} vs {want}"
            );
        }
    }
    let out = latlong_area(&half, Mapping::DualParaboloid, 32, DMat3::IDENTITY);
    let e = power_error(&out, &m);
    eprintln!("halved, then paraboloid 32: power error {e:.2e}");
    assert!(e <= 1e-5, "{e:e}");
}

/// The halving stops at the paraboloid's finest texel: 1024 × 512 to a paraboloid of 128
/// halves (512 columns, 0.70° ≤ 0.90°), to 256 does not (0.45°), nor to the map's own
/// size, nor a map of an odd side.
#[test]
fn halving_stops_at_the_finest_paraboloid_texel() {
    for (w, h, size, want) in [
        (1024, 512, 128, true),
        (1024, 512, 16, true),
        (1024, 512, 256, false),
        (1024, 512, 1024, false),
        (512, 256, 64, true),
        (512, 256, 128, false),
        (1024, 511, 16, false),
        (1023, 512, 16, false),
    ] {
        assert_eq!(
            paraboloid_source_halves(w, h, size),
            want,
            "{w}x{h} to {size}"
        );
    }
}

/// The twin's own check on the hard map of tests/convert.rs (suns 10⁵ × the sky at both
/// poles, on the seam and mid-sky): power within 3e-5 at 1024 → 256 and 255 (measured 5e-6
/// and 1.4e-5, the
/// chords of the footprint polygons; 2.2e-3 by 5 × 5 bilinear samples), at even and odd
/// sizes, and a constant map reproduced to 1e-12.
#[test]
fn area_conversion_conserves_power_and_constants() {
    use crate::math::Orientation;
    let (w, h) = (1024u32, 512u32);
    let mut m = EnvMap::from_fn(Mapping::LatLong, w, h, 1, |d| {
        [1.0 + 0.5 * (13.0 * d.x + 7.0 * d.y).sin(), 1.0, 1.0]
    });
    let (wu, hu) = (w as usize, h as usize);
    for (i, j) in [
        (0, 0),
        (wu / 2, 0),
        (0, hu / 2),
        (wu - 1, hu / 3),
        (wu / 3, hu - 1),
    ] {
        m.texels[j * wu + i] = [1e5, 2e5, 5e4];
    }
    for (n, rot) in [(256u32, 0.0), (255, 17.0)] {
        let o = Orientation {
            flip_u: false,
            flip_v: rot > 0.0,
            rotate_y_degrees: rot,
        };
        assert!(area_serves(w, h, Mapping::Cube, n, DMat3::IDENTITY));
        let out = latlong_area(&m, Mapping::Cube, n, o.world_to_file());
        let worst = power_error(&out, &m);
        assert!(worst <= 3e-5, "cube {n}: power off by {worst:e}");
    }
    // A paraboloid's rim is the equator, z = 0 in (U, z): its halves tile the plane too.
    // Turned about the axis and mirrored, which keep it; flipped upside down, which does
    // not (the sampled conversion serves that one).
    for (n, rot, flip_u) in [(256u32, 0.0, false), (255, 17.0, true), (64, 90.0, false)] {
        let o = Orientation {
            flip_u,
            flip_v: false,
            rotate_y_degrees: rot,
        };
        assert!(area_serves(
            w,
            h,
            Mapping::DualParaboloid,
            n,
            o.world_to_file()
        ));
        let out = latlong_area(&m, Mapping::DualParaboloid, n, o.world_to_file());
        let worst = power_error(&out, &m);
        eprintln!("paraboloid {n}: power off by {worst:.2e}");
        assert!(worst <= 3e-5, "paraboloid {n}: power off by {worst:e}");
    }
    let upside_down = Orientation {
        flip_u: false,
        flip_v: true,
        rotate_y_degrees: 0.0,
    };
    assert!(!area_serves(
        w,
        h,
        Mapping::DualParaboloid,
        64,
        upside_down.world_to_file()
    ));
    // Tiny outputs: one paraboloid texel a half holds its pole and the whole rim (its
    // boundary lies past the rim, in the other hemisphere: the pole it closes on is its
    // own half's); measured within 3.2e-8.
    let small = EnvMap::from_fn(Mapping::LatLong, 64, 32, 1, |d| {
        [
            1.0 + 0.5 * (13.0 * d.x + 7.0 * d.y).sin(),
            1.0 + 0.5 * d.y,
            1.0,
        ]
    });
    for (to, n) in [
        (Mapping::DualParaboloid, 1),
        (Mapping::DualParaboloid, 2),
        (Mapping::DualParaboloid, 3),
        (Mapping::Cube, 1),
        (Mapping::Cube, 2),
    ] {
        assert!(area_serves(64, 32, to, n, DMat3::IDENTITY));
        let out = latlong_area(&small, to, n, DMat3::IDENTITY);
        let worst = power_error(&out, &small);
        assert!(worst <= 1e-6, "{to:?} {n}: power off by {worst:e}");
    }
    let flat = EnvMap::new(Mapping::LatLong, 64, 32, vec![[2.0, 3.0, 4.0]; 64 * 32]);
    for (to, n) in [
        (Mapping::Cube, 1),
        (Mapping::Cube, 7),
        (Mapping::Cube, 8),
        (Mapping::DualParaboloid, 1),
        (Mapping::DualParaboloid, 7),
        (Mapping::DualParaboloid, 8),
    ] {
        let out = latlong_area(&flat, to, n, DMat3::IDENTITY);
        assert!(
            out.texels.iter().all(|t| *t == [2.0, 3.0, 4.0]),
            "{to:?} {n}"
        );
    }
}

/// The limited linear reconstruction is exact for a map linear in z = cos θ (the
/// limiter leaves monotone slopes whole, but for the polar rows, which are extrema), so
/// each cube texel gets the true mean of 2 + y over its footprint but for the polygons'
/// chords and those rows (measured 8.7e-5 at 64 x 32 → cube 8); held constant per texel
/// (slopes zeroed) it is first order (4.5e-3). A
/// lone bright texel keeps zero slopes (no ringing, never negative).
#[test]
fn area_reconstruction_is_second_order_and_flat_at_extrema() {
    let (w, h, n) = (64u32, 32u32, 8u32);
    // Each texel holds the exact mean of 2 + y over it: 2 + the mean of its band's z.
    let texels = (0..w * h)
        .map(|k| {
            let r = (k / w) as i64;
            [(2.0 + 0.5 * (band_edge(r, h as i64) + band_edge(r + 1, h as i64))) as f32; 3]
        })
        .collect();
    let map = EnvMap::new(Mapping::LatLong, w, h, texels);
    let out = latlong_area(&map, Mapping::Cube, n, DMat3::IDENTITY);
    let (wi, hi) = (w as i64, h as i64);
    let mut box_err: f64 = 0.0;
    let mut worst: f64 = 0.0;
    for face in 0..6 {
        for j in 0..n {
            for i in 0..n {
                // The true mean of 1 + y over the texel: 64 x 64 midpoint cells weighted by
                // the cube's solid-angle density.
                let (mut num, mut den) = (0.0, 0.0);
                for b in 0..64 {
                    for a in 0..64 {
                        let c = Coord {
                            layer: face,
                            u: (i as f64 + (a as f64 + 0.5) / 64.0) / n as f64,
                            v: (j as f64 + (b as f64 + 0.5) / 64.0) / n as f64,
                        };
                        let (s, t) = (2.0 * c.u - 1.0, 2.0 * c.v - 1.0);
                        let dw = (1.0 + s * s + t * t).powf(-1.5);
                        num += dw * (2.0 + Mapping::Cube.coord_to_dir(c).y);
                        den += dw;
                    }
                }
                let want = num / den;
                let got = out.texel(face, i, j)[0] as f64;
                worst = worst.max((got / want - 1.0).abs());
                let poly = area_polygon(
                    Mapping::Cube,
                    face,
                    i,
                    j,
                    n,
                    wi,
                    DMat3::IDENTITY,
                    area::EDGE_STEPS,
                );
                let flat = area_mean(&poly, wi, hi, |row, col| Cell {
                    l: fetch(&map, 0, col, row),
                    slopes: [[0.0; 3]; 2],
                })[0] as f64;
                box_err = box_err.max((flat / want - 1.0).abs());
            }
        }
    }
    eprintln!("linear in z: linear reconstruction {worst:.2e}, flat {box_err:.2e}");
    assert!(worst < 2e-4, "linear in z: off by {worst:e}");
    assert!(
        box_err > 1e-3,
        "the flat reconstruction should be first order ({box_err:e})"
    );
    let mut sun = EnvMap::new(Mapping::LatLong, w, h, vec![[1.0; 3]; (w * h) as usize]);
    sun.texels[(10 * w + 20) as usize] = [1e5; 3];
    let slopes = area_slopes(&sun);
    assert_eq!(slopes[(10 * w + 20) as usize], [[0.0; 3]; 2]);
    let out = latlong_area(&sun, Mapping::Cube, n, DMat3::IDENTITY);
    assert!(out.texels.iter().flatten().all(|v| *v >= 1.0 - 1e-6));
}

#[test]
fn row_centroids_match_quadrature() {
    let h = PI / 7.0;
    for j in 0..7 {
        let t0 = j as f64 * h;
        let n = 20000;
        let (mut num, mut den) = (0.0, 0.0);
        for k in 0..n {
            let t = t0 + (k as f64 + 0.5) / n as f64 * h;
            num += t * t.sin();
            den += t.sin();
        }
        assert!((num / den - row_centroid(j, h)).abs() < 1e-8, "row {j}");
    }
    // Across the pole the virtual rows mirror the real ones.
    assert!((row_centroid(-1, h) + row_centroid(0, h)).abs() < 1e-12);
    assert!((row_centroid(7, h) - (2.0 * PI - row_centroid(6, h))).abs() < 1e-12);
}

#[test]
fn sampling_a_constant_map_is_exact_everywhere() {
    for m in Mapping::ALL {
        let (w, h) = m.extent_for_size(5);
        let map = EnvMap::new(
            m,
            w,
            h,
            vec![[2.0, 3.0, 4.0]; (w * h * m.layers()) as usize],
        );
        for d in super::super::synth::stress_directions().iter().step_by(37) {
            let s = sample(&map, *d);
            assert!(
                (s[0] - 2.0).abs() < 1e-12 && (s[2] - 4.0).abs() < 1e-12,
                "{m:?} {d}: {s:?}"
            );
        }
    }
}

/// How many corners of texel (i, j) of a paraboloid of side `n` lie in the closed disc
/// (integers, as [`edge_steps`] decides).
fn corners_in_disc(n: u32, i: u32, j: u32) -> usize {
    let in_disc = |a: u32, b: u32| {
        let (s, t) = (2 * a as i64 - n as i64, 2 * b as i64 - n as i64);
        s * s + t * t <= (n * n) as i64
    };
    let corners = [(i, j), (i + 1, j), (i, j + 1), (i + 1, j + 1)];
    corners.iter().filter(|&&(a, b)| in_disc(a, b)).count()
}

/// A polygon's signed area in the (U, z) plane (the shoelace formula, as ∫ z dU adds it).
fn shoelace(p: &[[f64; 2]]) -> f64 {
    (0..p.len())
        .map(|k| {
            let (a, b) = (p[k], p[(k + 1) % p.len()]);
            0.5 * (b[0] - a[0]) * (a[1] + b[1])
        })
        .sum()
}

/// With its slivers a paraboloid texel's footprint is its solid angle: the chords' polygon
/// (by the shoelace formula in the (U, z) plane, where dω = (2π/W)·dU·dz) plus the slivers,
/// against `Mapping::texel_solid_angle`, for every texel of a 48² paraboloid whose edges all
/// take slivers, upright and turned about the axis. Measured, worst texel: 2.5e-6 at 1 chord
/// an edge, 3.0e-8 at 3 (the parabolas' error, largest just outside the pole's window; 4.4e-6
/// at 256²); the chords alone 3.0e-3 and 3.4e-4, so the slivers carry the area.
#[test]
fn slivers_make_footprints_their_solid_angles() {
    let (n, w) = (48u32, 512i64);
    let turned = crate::Orientation {
        flip_u: true,
        flip_v: false,
        rotate_y_degrees: 33.0,
    };
    for w2f in [DMat3::IDENTITY, turned.world_to_file()] {
        for (chords, bound) in [(1, 5e-6), (3, 1e-7)] {
            let (mut worst, mut chords_only, mut texels) = (0.0f64, 0.0f64, 0);
            for layer in 0..2 {
                for j in 0..n {
                    for i in 0..n {
                        if corners_in_disc(n, i, j) < 4
                            || area_general_texel(Mapping::DualParaboloid, layer, i, j, n)
                        {
                            continue;
                        }
                        let f =
                            area_polygon(Mapping::DualParaboloid, layer, i, j, n, w, w2f, chords);
                        assert_eq!(f.slivers.len(), 4 * chords as usize);
                        let shoelace = shoelace(&f.poly);
                        let slivers: f64 = f.slivers.iter().map(|s| s.1).sum();
                        let scale = std::f64::consts::TAU / w as f64;
                        let want = Mapping::DualParaboloid.texel_solid_angle(n, n, i, j);
                        let rel = |a: f64| ((a * scale).abs() / want - 1.0).abs();
                        worst = worst.max(rel(shoelace + slivers));
                        chords_only = chords_only.max(rel(shoelace));
                        texels += 1;
                    }
                }
            }
            eprintln!(
                "{chords} chords: {texels} texels, footprint vs solid angle {worst:.1e} \
                 (chords alone {chords_only:.1e})"
            );
            assert!(
                texels > 1000 && worst <= bound,
                "{chords} chords: {worst:e}"
            );
            assert!(
                chords_only > 100.0 * bound,
                "{chords} chords alone: {chords_only:e}"
            );
        }
    }
}

/// The rim's texels too: a paraboloid texel that the rim cuts has for its footprint its
/// chords' polygon clipped to its half plus its chords' slivers clipped there
/// ([`sliver_kept`]), against `Mapping::texel_solid_angle` (the square's part inside the disc),
/// for every such texel of 32² and 48² paraboloids, upright and turned about the axis, the
/// error relative to a whole rim texel's solid angle. Measured, worst texel: 2.7e-6 at
/// `area::PARABOLOID_RIM_STEPS` = 2 (the parabolas' error; 2.1e-7 at 4); the clipped chords
/// alone 1.7e-3.
#[test]
fn kept_slivers_make_rim_footprints_their_solid_angles() {
    let turned = crate::Orientation {
        flip_u: true,
        flip_v: false,
        rotate_y_degrees: 33.0,
    };
    let (mut worst, mut chords_only, mut texels) = (0.0f64, 0.0f64, 0);
    for (n, w) in [(32u32, 1024i64), (48, 512)] {
        for w2f in [DMat3::IDENTITY, turned.world_to_file()] {
            for layer in 0..2 {
                for j in 0..n {
                    for i in 0..n {
                        if matches!(corners_in_disc(n, i, j), 0 | 4) {
                            continue;
                        }
                        let f = area_polygon(Mapping::DualParaboloid, layer, i, j, n, w, w2f, 2);
                        let shoelace = shoelace(&cut(&f.poly, 0.0, layer == 0));
                        let slivers: f64 = f.slivers.iter().map(|s| s.1).sum();
                        let scale = std::f64::consts::TAU / w as f64;
                        let want = Mapping::DualParaboloid.texel_solid_angle(n, n, i, j);
                        // Of a whole texel at the rim, (2/n)² (dω = ds dt there): some
                        // texels keep a sliver of themselves inside the disc.
                        let full = (2.0 / n as f64).powi(2);
                        let rel = |a: f64| ((a * scale).abs() - want).abs() / full;
                        worst = worst.max(rel(shoelace + slivers));
                        chords_only = chords_only.max(rel(shoelace));
                        texels += 1;
                    }
                }
            }
        }
    }
    eprintln!("{texels} rim texels, footprint vs solid angle {worst:.1e} (chords alone {chords_only:.1e})");
    assert!(texels > 500 && worst <= 3.5e-6, "{worst:e}");
    assert!(chords_only > 100.0 * worst, "chords alone: {chords_only:e}");
}

/// What fewer chords cost ([`area::PARABOLOID_EDGE_STEPS`]): each sliver lands whole in the
/// source texel under its curve's midpoint, so a texel next to a sun moves against 8 chords
/// (whose slivers are 1/64 as large) by at most, measured on the sun sky: 512 × 256 to 128²,
/// 9.8e-2 at 1 chord and 2.5e-2 at 2; 1024 × 512 to 128², 4.6e-3 and 1.9e-3 (the mean texel
/// ~1e-5 and below). Bounds 1.3× those. Power is kept at every count (1e-7).
#[test]
fn fewer_chords_move_texels_next_to_a_sun_within_bounds() {
    let sky = crate::math::synth::Sky::default();
    for (w, bounds) in [(512u32, [0.128, 0.033]), (1024, [6.0e-3, 2.5e-3])] {
        let map = EnvMap::from_fn(Mapping::LatLong, w, w / 2, 1, |d| sky.radiance(d));
        let fine = latlong_area_points(&map, Mapping::DualParaboloid, 128, DMat3::IDENTITY, 8);
        for (chords, bound) in [1, 2].into_iter().zip(bounds) {
            let got =
                latlong_area_points(&map, Mapping::DualParaboloid, 128, DMat3::IDENTITY, chords);
            let worst = got
                .texels
                .iter()
                .zip(&fine.texels)
                .map(|(a, b)| (f64::from(a[0]) - f64::from(b[0])).abs() / f64::from(b[0]))
                .fold(0.0, f64::max);
            let power = power_error(&got, &map);
            eprintln!("{w} to 128, {chords} chords: worst texel {worst:.2e}, power {power:.1e}");
            assert!(
                worst <= bound && power <= 1e-7,
                "{w}, {chords}: {worst:e} {power:e}"
            );
        }
    }
}
