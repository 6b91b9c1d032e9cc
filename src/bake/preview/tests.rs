use super::*;
use crate::math::split_sum::dfg;
use crate::math::synth::smooth_env;

/// Cubes of `f` at `size` with `levels` levels, level k blurred towards the mean by k/levels
/// (so that levels differ), irradiance `e_scale`·E with E = π·(the map's mean) + a tilt.
fn cubes(f: impl Fn(DVec3) -> [f64; 3] + Copy + Sync, size: u32, levels: usize) -> PreviewCubes {
    let level = |k: usize| {
        let s = (size >> k).max(1);
        let t = k as f64 / levels as f64;
        EnvMap::from_fn(Mapping::Cube, s, s, 1, move |d| {
            f(d).map(|x| x * (1.0 - t) + 1.2 * t)
        })
    };
    PreviewCubes {
        specular: (0..levels).map(level).collect(),
        irradiance: EnvMap::from_fn(Mapping::Cube, 8, 8, 1, |d| {
            let e = std::f64::consts::PI * (1.0 + 0.3 * d.y);
            [e, 0.9 * e, 0.8 * e]
        }),
        irradiance_scale: 1.0,
        lights: Vec::new(),
    }
}

fn constant(l: [f64; 3], levels: usize) -> PreviewCubes {
    let mut c = cubes(move |_| l, 16, levels);
    for m in &mut c.specular {
        m.texels.iter_mut().for_each(|t| *t = l.map(|x| x as f32));
    }
    c.irradiance = EnvMap::from_fn(Mapping::Cube, 4, 4, 1, move |_| {
        l.map(|x| x * std::f64::consts::PI)
    });
    c
}

fn mirrored(c: &PreviewCubes) -> PreviewCubes {
    let mut out = c.clone();
    for m in &mut out.specular {
        let (w, h) = (m.width, m.height);
        let src = m.clone();
        for layer in 0..6 {
            for j in 0..h {
                for i in 0..w {
                    let k = m.index(layer, i, j);
                    m.texels[k] = src.texel(layer, w - 1 - i, j);
                }
            }
        }
    }
    out
}

#[test]
fn a_constant_environment_shades_as_the_recipe_says() {
    let l = [0.7, 1.1, 2.3];
    let p = render(&constant(l, 5), DMat3::IDENTITY);
    let first = -SPACING * (SPHERES.len() - 1) as f64 / 2.0;
    let mut seen = [0usize; 5];
    for y in 0..p.height {
        for x in 0..p.width {
            let k = (y * p.width + x) as usize;
            let (got, s) = (p.rgb[k], p.sphere[k]);
            let want = match SPHERES.get(s as usize) {
                None | Some(Sphere::Mirror) | Some(Sphere::Diffuse) => l,
                // The quadrature oracle on every 5th pixel (0.2 ms each).
                Some(Sphere::Ggx(_)) if (x + y) % 5 != 0 => got,
                Some(Sphere::Ggx(a)) => {
                    // n and v of this pixel, as render() finds them.
                    let d = DVec3::new(
                        (x as f64 + 0.5 - WIDTH as f64 / 2.0) / FOCAL,
                        (ROW as f64 / 2.0 - y as f64 - 0.5) / FOCAL,
                        -1.0,
                    )
                    .normalize();
                    let c = DVec3::new(first + SPACING * s as f64, 0.0, -DEPTH);
                    let b = d.dot(c);
                    let n = (d * (b - (b * b - c.length_squared() + 1.0).sqrt()) - c).normalize();
                    let ab = dfg(*a, true, n.dot(-d));
                    l.map(|x| x * (ab[0] + ab[1]))
                }
            };
            if (s as usize) < seen.len() {
                seen[s as usize] += 1;
            }
            for ch in 0..3 {
                // The albedo table (33 steps, Catmull–Rom) is within 2e-3 of the quadrature's A + B.
                let tol = if matches!(SPHERES.get(s as usize), Some(Sphere::Ggx(_))) {
                    2e-3
                } else {
                    1e-6
                };
                assert!(
                    (got[ch] - want[ch]).abs() <= tol * want[ch],
                    "pixel ({x}, {y}), sphere {s}: {got:?} against {want:?}"
                );
            }
        }
    }
    // Each sphere covers about π·49² pixels (radius 1 at depth 8, focal length 394; more at
    // the ends, seen obliquely).
    for (k, n) in seen.iter().enumerate() {
        assert!(
            (6000..10000).contains(n),
            "sphere {k} covers {n} pixels: {seen:?}"
        );
    }
}

#[test]
fn the_same_cubes_agree_and_each_breakage_shows_on_its_spheres() {
    let c = cubes(smooth_env, 32, 6);
    let world = DMat3::IDENTITY;
    let want = render(&c, world);
    assert!(sphere_errors(&render(&c.clone(), world), &want)
        .iter()
        .all(|e| *e == 0.0));

    // The texels rounded to half floats (rgba16f's loss): far below 1%.
    let mut half = c.clone();
    for m in half
        .specular
        .iter_mut()
        .chain(std::iter::once(&mut half.irradiance))
    {
        for t in &mut m.texels {
            *t = t.map(|x| half::f16::from_f32(x).to_f32());
        }
    }
    let e = sphere_errors(&render(&half, world), &want);
    assert!(e.iter().all(|e| *e < 1e-3), "rgba16f rounding: {e:?}");

    // Each face mirrored: the mirror and the sharp GGX spheres move.
    let e = sphere_errors(&render(&mirrored(&c), world), &want);
    assert!(e[0] > 0.05 && e[1] > 0.02, "mirrored: {e:?}");
    // Irradiance read as E where it is E/π (or π× too bright): the diffuse sphere, by π − 1.
    let mut bright = c.clone();
    bright.irradiance_scale = 1.0 / std::f64::consts::PI;
    let e = sphere_errors(&render(&bright, world), &want);
    assert!(
        (e[4] - (std::f64::consts::PI - 1.0)).abs() < 1e-9,
        "π×: {e:?}"
    );
    assert!(e[..4].iter().all(|e| *e == 0.0));
    // Levels in reverse roughness order: the GGX spheres.
    let mut reversed = c.clone();
    let n = reversed.specular.len();
    for k in 0..n {
        let from = &c.specular[n - 1 - k];
        let s = reversed.specular[k].width;
        reversed.specular[k] =
            EnvMap::from_fn(Mapping::Cube, s, s, 1, |d| convert::sample(from, d));
    }
    let e = sphere_errors(&render(&reversed, world), &want);
    assert!(e[1..4].iter().all(|e| *e > 0.02), "reversed levels: {e:?}");
    // Read in the wrong frame (a preset's turn missing): every sphere that looks at the
    // environment moves.
    let turned = DMat3::from_rotation_y(std::f64::consts::FRAC_PI_2);
    let e = sphere_errors(&render(&c, turned), &want);
    assert!(e[0] > 0.05, "turned: {e:?}");
}

#[test]
fn separated_lights_are_added_back_as_directional_lights() {
    let c = constant([0.0; 3], 3);
    let mut lit = c.clone();
    let l = DVec3::new(0.0, 0.0, 1.0);
    lit.lights.push(AddedLight {
        direction: l,
        illuminance: [2.0, 1.0, 0.5],
    });
    let p = render(&lit, DMat3::IDENTITY);
    // The diffuse sphere's pixel nearest its centre faces the camera (+Z): E·(n·l)/π.
    let first = -SPACING * (SPHERES.len() - 1) as f64 / 2.0;
    let cx = WIDTH as f64 / 2.0 + FOCAL * (first + SPACING * 4.0) / DEPTH;
    let k = ((ROW / 2) * WIDTH + cx as u32) as usize;
    assert_eq!(p.sphere[k], 4);
    let d = DVec3::new(
        (cx.floor() + 0.5 - WIDTH as f64 / 2.0) / FOCAL,
        -0.5 / FOCAL,
        -1.0,
    )
    .normalize();
    let c0 = DVec3::new(first + SPACING * 4.0, 0.0, -DEPTH);
    let b = d.dot(c0);
    let n = (d * (b - (b * b - c0.length_squared() + 1.0).sqrt()) - c0).normalize();
    let want = [2.0, 1.0, 0.5].map(|e| e * n.dot(l) / std::f64::consts::PI);
    for ch in 0..3 {
        assert!(
            (p.rgb[k][ch] - want[ch]).abs() < 1e-12 * want[0],
            "{:?} vs {want:?}",
            p.rgb[k]
        );
    }
    // A mirror shows no delta light; the GGX spheres do.
    let unlit = render(&c, DMat3::IDENTITY);
    let e = sphere_errors(&unlit, &p);
    assert_eq!(e[0], 0.0);
    assert!(e[1..].iter().all(|e| *e == 1.0), "{e:?}");
}

#[test]
fn the_png_states_its_tone_mapping_and_decodes() {
    let c = cubes(smooth_env, 16, 4);
    let p = render(&c, DMat3::IDENTITY);
    let check = PreviewCheck {
        files_vs_intent: sphere_errors(&p, &p),
        worst: 0.0,
        exposure: exposure(&p),
        recipe_vs_reference: Vec::new(),
    };
    assert!(check.exposure.is_finite() && check.exposure != 0.0);
    let bytes = picture::png(&p, &check, None).unwrap();
    let img = image::load_from_memory(&bytes).unwrap().into_rgb8();
    assert_eq!((img.width(), img.height()), PREVIEW_SIZE);
    // The caption holds text (lit pixels on its dark ground), the row a picture.
    let caption = img
        .rows()
        .skip(ROW as usize)
        .flatten()
        .filter(|p| p.0[0] > 100)
        .count();
    assert!(caption > 500, "{caption} lit caption pixels");
    let distinct: std::collections::HashSet<[u8; 3]> = img
        .rows()
        .take(ROW as usize)
        .flatten()
        .map(|p| p.0)
        .collect();
    assert!(
        distinct.len() > 100,
        "{} colours in the row",
        distinct.len()
    );
}
