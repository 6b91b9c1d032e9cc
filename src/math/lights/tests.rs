//! The unit tests of `lights` (a file of their own: the module stays readable).

use super::*;
use crate::math::mapping::Mapping;
use crate::math::synth::{smooth_env, Sky};

fn sky_map(mapping: Mapping, size: u32) -> EnvMap {
    let sky = Sky::default();
    let (w, h) = mapping.extent_for_size(size);
    EnvMap::from_fn(mapping, w, h, 2, move |d| sky.radiance(d))
}

/// Lights plus residual give back every texel to float32 rounding, and the power to
/// 1e-6; the residual's luminance never exceeds τ (to rounding).
#[test]
fn lights_plus_residual_are_the_map() {
    for mapping in [
        Mapping::LatLong,
        Mapping::Cube,
        Mapping::Angular,
        Mapping::DualParaboloid,
    ] {
        let map = sky_map(mapping, 64);
        let filled = ExtractOptions {
            fill: Some(2),
            ..ExtractOptions::default()
        };
        for opts in [ExtractOptions::default(), filled] {
            let ex = extract(&map, &opts);
            add_back(&map, &ex, mapping);
        }
    }
}

/// Checks that `ex`'s lights plus its residual give back `map`.
fn add_back(map: &EnvMap, ex: &Extraction, mapping: Mapping) {
    assert!(!ex.lights.is_empty(), "{mapping:?}");
    let mut back = ex.residual.clone();
    for t in &ex.lights {
        let (si, sj) = map
            .mapping
            .integration_source(map.width, map.height, t.i, t.j)
            .unwrap();
        if (si, sj) == (t.i, t.j) {
            let k = back.index(t.layer, t.i, t.j);
            for c in 0..3 {
                back.texels[k][c] += t.radiance[c];
            }
        }
    }
    for (a, b) in back.texels.iter().zip(&map.texels) {
        for c in 0..3 {
            assert!(
                (a[c] - b[c]).abs() <= 2.0 * f32::EPSILON * b[c],
                "{a:?} {b:?}"
            );
        }
    }
    let p_map = luminance(map.stats().power);
    let p_res = luminance(ex.residual.stats().power);
    let p_lights: f64 = ex
        .lights
        .iter()
        .map(|t| luminance(t.radiance.map(f64::from)) * t.omega)
        .sum();
    assert!(
        ((p_res + p_lights) - p_map).abs() <= 1e-6 * p_map,
        "{mapping:?}"
    );
    let top = ex.residual.stats().max_luminance;
    assert!(
        top <= ex.threshold * (1.0 + 1e-6),
        "{mapping:?}: {top} > {}",
        ex.threshold
    );
}

/// A softbox (a bright disc with a glow at its edge) over a gradient. Clamped, the
/// residual under it is a plateau at τ: its worst distance from the gradient is 0.93 τ.
/// Filled, with two rings grown over the glow, the residual continues the gradient
/// (measured 0.008 τ; bound 1/20 of the clamp's). A cap without room for a ring keeps
/// the light set and fills from the glow's texels below τ (0.84 τ: why the rings).
#[test]
fn filled_residual_continues_the_surroundings() {
    let ground = |d: DVec3| 1.0 + 0.5 * d.x + 0.25 * d.y;
    let centre = DVec3::new(0.3, 0.2, 0.9).normalize();
    let softbox = move |d: DVec3| {
        // A disc of chord radius 0.15, 1000 × the ground, whose glow falls by e every
        // 0.01 beyond it (about 0.4 texel): the texels two out sit below τ, above ground.
        let out = ((d - centre * d.dot(centre)).length() - 0.15).max(0.0);
        let glow = if d.dot(centre) > 0.0 {
            1000.0 * (-out / 0.01).exp()
        } else {
            0.0
        };
        let y = ground(d) + glow;
        [y, y, y]
    };
    for mapping in [Mapping::LatLong, Mapping::Angular] {
        let (w, h) = mapping.extent_for_size(128);
        let map = EnvMap::from_fn(mapping, w, h, 1, softbox);
        let opts = ExtractOptions {
            ratio: 2.0,
            max_texels: usize::MAX,
            fill: None,
        };
        let clamped = extract(&map, &opts);
        let filled = extract(
            &map,
            &ExtractOptions {
                fill: Some(2),
                ..opts
            },
        );
        add_back(&map, &filled, mapping);
        assert!(filled.lights.len() > clamped.lights.len(), "{mapping:?}");
        // Worst distance of the residual from the gradient, as a share of τ: under the
        // lights, and anywhere (the ramp included).
        let under = |ex: &Extraction| {
            let mut worst = 0.0f64;
            for t in &ex.lights {
                let r = luminance(ex.residual.texel(t.layer, t.i, t.j).map(f64::from));
                worst = worst.max((r - ground(t.dir)).abs());
            }
            worst / ex.threshold
        };
        let anywhere = |ex: &Extraction| {
            let mut worst = 0.0f64;
            ex.residual.for_each_texel(|layer, i, j, t, _| {
                let r = luminance(t.map(f64::from));
                worst = worst.max((r - ground(map.texel_dir(layer, i, j))).abs());
            });
            worst / ex.threshold
        };
        // A cap at the clamped count leaves no room for a ring.
        let tight = extract(
            &map,
            &ExtractOptions {
                max_texels: clamped.lights.len(),
                fill: Some(2),
                ..opts
            },
        );
        assert_eq!(tight.lights.len(), clamped.lights.len(), "{mapping:?}");
        let (c, f, t) = (
            [under(&clamped), anywhere(&clamped)],
            [under(&filled), anywhere(&filled)],
            [under(&tight), anywhere(&tight)],
        );
        assert!(c[0] > 0.5 && c[1] > 0.5, "{mapping:?}: {c:?}");
        assert!(f[1] < 0.05 * c[1], "{mapping:?}: {f:?} {c:?}");
        assert!(t[0] <= c[0], "{mapping:?}: {t:?} {c:?}");
        add_back(&map, &tight, mapping);
    }
}

/// The sun of a sky 5·10⁴ × its zenith is one light, in the sun's direction, holding the
/// same share of the power on every mapping (to 2%: their texels differ); a smooth map
/// has no light; the cap holds, keeping the brightest.
#[test]
fn the_sun_is_one_light_on_every_mapping() {
    let sky = Sky::default();
    let mut shares = Vec::new();
    for mapping in [
        Mapping::LatLong,
        Mapping::Cube,
        Mapping::Angular,
        Mapping::DualParaboloid,
    ] {
        let map = sky_map(mapping, 128);
        let ex = extract(&map, &ExtractOptions::default());
        let lights = group(&map, &ex, 0.1);
        assert_eq!(lights.len(), 1, "{mapping:?}: {lights:?}");
        let d = DVec3::from_array(lights[0].direction);
        assert!(
            d.dot(sky.sun_dir) > (1f64).to_radians().cos(),
            "{mapping:?}: {d}"
        );
        shares.push(lights[0].share);
        // Deterministic.
        let again = extract(&map, &ExtractOptions::default());
        assert_eq!(again.lights, ex.lights);
    }
    for s in &shares {
        assert!((s - shares[0]).abs() < 0.02 * shares[0], "{shares:?}");
    }
    assert!(shares[0] > 0.5, "{shares:?}");
    let smooth = EnvMap::from_fn(Mapping::LatLong, 64, 32, 1, smooth_env);
    assert!(extract(&smooth, &ExtractOptions::default())
        .lights
        .is_empty());
    // A limb-darkened sun, so that the cap falls between distinct luminances (texels
    // tied at the cap are all left out: their excess over it would be 0).
    let map = EnvMap::from_fn(Mapping::LatLong, 512, 256, 2, move |d| {
        let a = d.dot(sky.sun_dir).clamp(-1.0, 1.0).acos() / sky.sun_radius;
        sky.radiance(d)
            .map(|c| if a < 1.0 { c * (2.0 - a) } else { c })
    });
    let all = extract(&map, &ExtractOptions::default());
    let capped = extract(
        &map,
        &ExtractOptions {
            max_texels: 8,
            ..ExtractOptions::default()
        },
    );
    assert!(all.lights.len() > 8, "{}", all.lights.len());
    assert!(capped.lights.len() <= 8 && !capped.lights.is_empty());
    assert!(capped.threshold > all.threshold);
    let brightest = |e: &Extraction| {
        e.lights
            .iter()
            .map(|t| luminance(map.texel(t.layer, t.i, t.j).map(f64::from)))
            .fold(0.0, f64::max)
    };
    assert_eq!(brightest(&capped), brightest(&all));
}

/// A light texel's nodes (2 × 2 cells): weights summing to its solid angle, directions
/// inside it.
#[test]
fn nodes_cover_their_texel() {
    for mapping in [Mapping::LatLong, Mapping::Cube, Mapping::Angular] {
        let map = sky_map(mapping, 64);
        let ex = extract(&map, &ExtractOptions::default());
        for t in &ex.lights {
            let n = nodes(&map, t, 2);
            let w: f64 = n.iter().map(|n| n.1).sum();
            assert!((w - t.omega).abs() <= 1e-12 * t.omega);
            for (d, _) in &n {
                assert_eq!(texel_of(&map, *d), (t.layer, t.i, t.j), "{mapping:?}");
            }
        }
    }
}

/// Clusters never exceed their texels' irradiance (max(0, Σa) ≤ Σ max(0, a)) and fall
/// short of it by at most the texels just below n's horizon (within a cell's diameter, so
/// their cell may straddle it): Σ L·Ω·|n·ω| over −sin D ≤ n·ω < 0, D the diagonal of a
/// grid cell at the equator. On two softboxes (lat-long and cube, turned), over 500
/// normals; a fifth or more meet no straddling cell and agree to 1e-12.
#[test]
fn clusters_sum_their_texels_exactly_off_the_horizon() {
    let f2w = crate::math::Orientation {
        flip_u: true,
        flip_v: false,
        rotate_y_degrees: 30.0,
    }
    .world_to_file()
    .transpose();
    let grid = CLUSTER_GRID;
    let diameter =
        (2.0 * std::f64::consts::PI / grid as f64).hypot(std::f64::consts::PI / (grid / 2) as f64);
    for mapping in [Mapping::LatLong, Mapping::Cube] {
        // Two wide softboxes, coloured, on a dim room: many texels per cell.
        let (w, h) = mapping.extent_for_size(256);
        let map = EnvMap::from_fn(mapping, w, h, 2, |d| {
            let a = (-(d - DVec3::new(0.6, 0.8, 0.0)).length_squared() / 0.08).exp();
            let b = (-(d - DVec3::new(-0.7, 0.1, 0.7)).length_squared() / 0.03).exp();
            [
                0.2 + 30.0 * a + 5.0 * b,
                0.3 + 25.0 * a + 9.0 * b,
                0.25 + 20.0 * a + 12.0 * b,
            ]
        });
        let ex = extract(&map, &diffuse_options(DIFFUSE_RATIO));
        let cl = clusters(&ex, f2w, grid);
        let counts = (ex.lights.len(), cl.len());
        assert!(
            counts.0 > 4 * counts.1 && counts.1 > 10,
            "{mapping:?} {counts:?}"
        );
        let total: f64 = ex
            .lights
            .iter()
            .map(|t| t.radiance[1] as f64 * t.omega)
            .sum();
        let mut exact_normals = 0;
        for k in 0..500 {
            let z = 1.0 - (2.0 * k as f64 + 1.0) / 500.0;
            let phi = k as f64 * 2.399963229728653;
            let s = (1.0 - z * z).sqrt();
            let n = DVec3::new(s * phi.cos(), s * phi.sin(), z);
            let got = cluster_irradiance(&cl, n);
            let (mut want, mut slack) = ([0.0; 3], [0.0; 3]);
            for t in &ex.lights {
                let c = n.dot(f2w * t.dir);
                for ch in 0..3 {
                    let p = t.radiance[ch] as f64 * t.omega;
                    want[ch] += p * c.max(0.0);
                    if c < 0.0 && c >= -diameter.sin() {
                        slack[ch] += p * -c;
                    }
                }
            }
            for ch in 0..3 {
                let d = want[ch] - got[ch];
                assert!(
                    d >= -1e-12 * total && d <= slack[ch] + 1e-12 * total,
                    "{mapping:?} n {n} ch {ch}: {} vs {} (slack {})",
                    got[ch],
                    want[ch],
                    slack[ch]
                );
            }
            if (want[1] - got[1]).abs() <= 1e-12 * total {
                exact_normals += 1;
            }
        }
        eprintln!("{mapping:?}: {counts:?} texels, clusters; {exact_normals} of 500 normals exact");
        assert!(exact_normals > 100, "{mapping:?}: {exact_normals}");
    }
}

/// The whole map's SH less the light texels' ([`light_sh`]) is the residual's projection
/// on lat-long and cube maps, turned, at order 8: within 2e-6 of L00, the float32 rounding
/// of the split (excess and residual are each rounded; measured 5.6e-7 on the cube, whose
/// sun texels are brighter, and below 1e-9 on the lat-long).
#[test]
fn whole_less_lights_is_the_residual_sh() {
    let f2w = crate::math::Orientation {
        flip_u: false,
        flip_v: true,
        rotate_y_degrees: 70.0,
    }
    .world_to_file()
    .transpose();
    for mapping in [Mapping::LatLong, Mapping::Cube] {
        let map = sky_map(mapping, 32);
        let ex = extract(&map, &diffuse_options(DIFFUSE_RATIO));
        assert!(!ex.lights.is_empty());
        let whole = super::super::sh::project_oriented(&map, 8, f2w);
        let res = super::super::sh::project_oriented(&ex.residual, 8, f2w);
        let lights = light_sh(&map, &ex, f2w, 8);
        let scale = whole[0][1].abs();
        for k in 0..whole.len() {
            for ch in 0..3 {
                let d = (whole[k][ch] - lights[k][ch] - res[k][ch]).abs();
                assert!(d < 2e-6 * scale, "{mapping:?} k {k} ch {ch}: {d:e}");
            }
        }
    }
}
