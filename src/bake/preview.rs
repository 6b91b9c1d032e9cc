//! A probe's preview, `preview.png`: the skybox behind a row of spheres (a mirror, white GGX
//! metals of α 0.1, 0.3 and 0.6, and a white diffuse sphere) rendered **from the files as
//! written**, read the way an engine reads them, and its check, **files against intent**: the
//! same spheres by the same recipe from envlight's own float data before writing. What the
//! files lost or turned (texel format, clamping, frame, irradiance scale, level order) is all
//! that differs between the two.
//!
//! The recipe is the split-sum one the presets' consumers use: the specular cube read at
//! lod = √α·(levels − 1), trilinear between levels and seamless across faces, times the
//! directional albedo A + B of GGX (F = 1, height-correlated Smith) at n·v; the mirror is
//! level 0; the diffuse sphere is E/π from the irradiance cube, whatever normalisation the
//! consumer stores (E or E/π). Where a bake separated its lights, each `lights.json` light is
//! added back as a directional light, as an engine adds a `KHR_lights_punctual` light (the
//! mirror, a delta lobe, shows none). The camera looks along the world's −Z with +Y up; a
//! world direction `d` reads the cube at `cube_to_worldᵀ·d` (the preset's frame).
//!
//! The check compares linear radiance, per sphere, as a relative RMS over its pixels and
//! channels; the picture is tone-mapped (stated on it) for people only.

use super::files::cube_image as cube;
use super::output::SeparateLights;
use super::plan::{BakePlan, Container};
use super::Baked;
use crate::error::{Error, Result};
use crate::math::envmap::luminance;
use crate::math::split_sum::MU_MIN;
use crate::math::{convert, Mapping};
use crate::EnvMap;
use glam::{DMat3, DVec3};
use serde::{Deserialize, Serialize};
use std::path::Path;
use std::sync::OnceLock;

pub mod breakage;
mod font;
mod picture;
pub mod reference;

/// The preview's file name in a probe's folder.
pub const PREVIEW_FILE: &str = "preview.png";

/// A sphere of the row, left to right.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Sphere {
    /// A perfect mirror: the specular cube's level 0 along the reflection.
    Mirror,
    /// A white GGX metal of this α by split-sum.
    Ggx(f64),
    /// A white Lambertian sphere: E/π.
    Diffuse,
}

impl Sphere {
    /// Its label on the picture.
    pub fn label(self) -> String {
        match self {
            Sphere::Mirror => "MIRROR".into(),
            Sphere::Ggx(a) => format!("GGX {a}"),
            Sphere::Diffuse => "DIFFUSE".into(),
        }
    }
}

/// The row, left to right.
pub const SPHERES: [Sphere; 5] = [
    Sphere::Mirror,
    Sphere::Ggx(0.1),
    Sphere::Ggx(0.3),
    Sphere::Ggx(0.6),
    Sphere::Diffuse,
];

/// The preview's size in pixels: the row of spheres, its caption, and the recipe's heat maps.
pub const PREVIEW_SIZE: (u32, u32) = (WIDTH, ROW + CAPTION + picture::HEAT);

/// The picture's width and the spheres' row height, in pixels.
const WIDTH: u32 = 640;
const ROW: u32 = 160;
/// The caption under the row: labels, the check, the tone mapping.
const CAPTION: u32 = 58;
/// Sphere centres (x), all at y = 0, z = −DEPTH, radius 1; the focal length in pixels.
const SPACING: f64 = 2.4;
const DEPTH: f64 = 8.0;
const FOCAL: f64 = 394.0;
/// Where a pixel shows no sphere.
const SKY: u8 = u8::MAX;

/// A light an engine adds beside the cubes: its direction (towards it) in the cube frame and
/// its illuminance on a surface facing it, per channel.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AddedLight {
    /// Unit direction towards the light, cube frame.
    pub direction: DVec3,
    /// ∑ L·Ω per channel.
    pub illuminance: [f64; 3],
}

/// The cubes a preview reads, as float texels in the cube frame.
#[derive(Clone, Debug)]
pub struct PreviewCubes {
    /// The specular cube's levels, level 0 first.
    pub specular: Vec<EnvMap>,
    /// The irradiance cube.
    pub irradiance: EnvMap,
    /// What one unit of irradiance is stored as: 1 for E, 1/π for E/π.
    pub irradiance_scale: f64,
    /// Lights added back (those a bake separated).
    pub lights: Vec<AddedLight>,
}

fn added(lights: &SeparateLights) -> Vec<AddedLight> {
    lights
        .lights
        .iter()
        .map(|l| AddedLight {
            direction: DVec3::from(l.direction),
            illuminance: l.illuminance,
        })
        .collect()
}

impl PreviewCubes {
    /// Envlight's own float data before writing (the intent): the GPU's cubes, irradiance as
    /// E, the separated lights as computed.
    pub fn intent(baked: &Baked, plan: &BakePlan, lights: Option<&SeparateLights>) -> Self {
        let o = &plan.options;
        PreviewCubes {
            specular: baked
                .specular
                .iter()
                .enumerate()
                .map(|(k, level)| cube(level, (o.specular_size >> k).max(1)))
                .collect(),
            irradiance: cube(&baked.irradiance, o.irradiance_size),
            irradiance_scale: 1.0,
            lights: lights.map(added).unwrap_or_default(),
        }
    }

    /// The cubes as the files in `dir` hold them, read as the plan's consumer reads them: the
    /// preset's irradiance normalisation (else the plan's), every level the specular file
    /// has, and `lights.json` where the plan separates lights.
    pub fn from_files(dir: &Path, plan: &BakePlan) -> Result<Self> {
        let (specular, irradiance) = match plan.container {
            Container::Ktx2 => (
                ktx2_cube(&dir.join("specular.ktx2"))?,
                ktx2_cube(&dir.join("irradiance.ktx2"))?
                    .into_iter()
                    .next()
                    .ok_or_else(|| Error::bad_file(dir.join("irradiance.ktx2"), "no levels"))?,
            ),
            Container::Exr => exr_cubes(dir)?,
        };
        let irradiance_scale = match plan.preset {
            Some(p) => p.irradiance().scale(),
            None => plan.irradiance.scale(),
        } as f64;
        let lights = match plan.lights {
            super::plan::LightsMode::Separate => read_lights(&dir.join("lights.json"))?,
            _ => Vec::new(),
        };
        Ok(PreviewCubes {
            specular,
            irradiance,
            irradiance_scale,
            lights,
        })
    }
}

fn read(path: &Path) -> Result<Vec<u8>> {
    std::fs::read(path).map_err(|source| Error::Io {
        path: path.to_path_buf(),
        source,
    })
}

/// A KTX2 cube's levels.
fn ktx2_cube(path: &Path) -> Result<Vec<EnvMap>> {
    let t =
        crate::io::ktx2::decode(&read(path)?).map_err(|e| e.context(path.display().to_string()))?;
    if t.faces != 6 || t.width != t.height {
        return Err(Error::bad_file(path, "not a cube with square faces"));
    }
    Ok(t.levels
        .iter()
        .enumerate()
        .map(|(k, level)| cube(level, (t.width >> k).max(1)))
        .collect())
}

/// The EXR container's specular levels and irradiance cube.
fn exr_cubes(dir: &Path) -> Result<(Vec<EnvMap>, EnvMap)> {
    let opts = crate::io::LoadOptions::new(Some(Mapping::Cube));
    let irradiance = crate::io::load(dir.join("irradiance.exr"), &opts)?;
    let mut specular = Vec::new();
    loop {
        let p = dir.join(format!("specular.level{}.exr", specular.len()));
        if !p.is_file() {
            break;
        }
        specular.push(crate::io::load(&p, &opts)?);
    }
    if specular.is_empty() {
        return Err(Error::bad_file(dir.join("specular.level0.exr"), "missing"));
    }
    Ok((specular, irradiance))
}

/// `lights.json`'s lights (cube-frame direction, illuminance).
fn read_lights(path: &Path) -> Result<Vec<AddedLight>> {
    let v: serde_json::Value = serde_json::from_slice(&read(path)?)
        .map_err(|e| Error::bad_file(path, format!("not JSON: {e}")))?;
    let bad = || Error::bad_file(path, "a light without a direction or an illuminance");
    let three = |x: &serde_json::Value| -> Option<[f64; 3]> {
        let a = x.as_array()?;
        Some([
            a.first()?.as_f64()?,
            a.get(1)?.as_f64()?,
            a.get(2)?.as_f64()?,
        ])
    };
    let lights = v["lights"].as_array().ok_or_else(bad)?;
    lights
        .iter()
        .map(|l| {
            Ok(AddedLight {
                direction: DVec3::from(three(&l["direction"]).ok_or_else(bad)?).normalize_or_zero(),
                illuminance: three(&l["illuminance"]).ok_or_else(bad)?,
            })
        })
        .collect()
}

/// The directional albedo A + B of the row's GGX spheres, tabulated at [`MU_STEPS`] steps
/// of t = √((n·v − μmin)/(1 − μmin)), dense at grazing views where it changes fastest
/// (worked out once a process; Catmull–Rom in t between steps).
const MU_STEPS: usize = 33;

fn albedo(alpha: f64, mu: f64) -> f64 {
    static TABLE: OnceLock<Vec<(f64, [f64; MU_STEPS])>> = OnceLock::new();
    let table = TABLE.get_or_init(|| {
        SPHERES
            .iter()
            .filter_map(|s| match *s {
                Sphere::Ggx(a) => Some(a),
                _ => None,
            })
            .map(|a| {
                let row = std::array::from_fn(|i| {
                    let t = i as f64 / (MU_STEPS - 1) as f64;
                    let mu = MU_MIN + (1.0 - MU_MIN) * t * t;
                    directional_albedo(a, mu)
                });
                (a, row)
            })
            .collect()
    });
    let Some((_, row)) = table.iter().find(|(a, _)| *a == alpha) else {
        return directional_albedo(alpha, mu);
    };
    let x = ((mu.clamp(MU_MIN, 1.0) - MU_MIN) / (1.0 - MU_MIN)).sqrt() * (MU_STEPS - 1) as f64;
    let i = (x.floor() as usize).min(MU_STEPS - 2);
    let f = x - i as f64;
    // Catmull–Rom between steps i and i + 1 (the ends repeated).
    let at = |k: isize| row[k.clamp(0, MU_STEPS as isize - 1) as usize];
    let (p0, p1, p2, p3) = (
        at(i as isize - 1),
        at(i as isize),
        at(i as isize + 1),
        at(i as isize + 2),
    );
    p1 + 0.5
        * f
        * (p2 - p0 + f * (2.0 * p0 - 5.0 * p1 + 4.0 * p2 - p3 + f * (3.0 * (p1 - p2) + p3 - p0)))
}

/// A + B (F = 1) of GGX α at n·v = `mu`: [`crate::math::brdf::Brdf::albedo`]'s quadrature
/// with 16 × 16 panels of 4 × 4 nodes (the recipe's albedo, not an oracle).
fn directional_albedo(alpha: f64, mu: f64) -> f64 {
    let mu = mu.clamp(MU_MIN, 1.0);
    let wo = DVec3::new((1.0 - mu * mu).max(0.0).sqrt(), 0.0, mu);
    crate::math::split_sum::ggx(alpha, true).albedo_rule(wo, 16, 4)
}

/// The specular cube read at `lod`, trilinear between levels.
fn specular_at(levels: &[EnvMap], c: DVec3, lod: f64) -> [f64; 3] {
    let last = levels.len().saturating_sub(1);
    let lod = lod.clamp(0.0, last as f64);
    let i = (lod.floor() as usize).min(last);
    let f = lod - i as f64;
    let a = convert::sample(&levels[i], c);
    if f <= 0.0 || i == last {
        return a;
    }
    let b = convert::sample(&levels[i + 1], c);
    [0, 1, 2].map(|k| a[k] * (1.0 - f) + b[k] * f)
}

/// A rendered row: linear RGB per pixel and which sphere each pixel shows.
#[derive(Clone, Debug)]
pub struct Picture {
    /// Pixels across.
    pub width: u32,
    /// Pixels down.
    pub height: u32,
    /// Linear radiance, row by row.
    pub rgb: Vec<[f64; 3]>,
    /// The sphere (index into [`SPHERES`]) each pixel shows, or 255 for the sky.
    pub sphere: Vec<u8>,
}

/// The radiance sphere `s` sends towards the eye at normal `n`, view `v` (towards the eye),
/// both in the cube frame.
fn shade(cubes: &PreviewCubes, s: Sphere, n: DVec3, v: DVec3) -> [f64; 3] {
    let r = 2.0 * n.dot(v) * n - v;
    let levels = cubes.specular.len() as f64;
    let mut out = match s {
        Sphere::Mirror => specular_at(&cubes.specular, r, 0.0),
        Sphere::Ggx(a) => {
            let p = specular_at(&cubes.specular, r, a.sqrt() * (levels - 1.0));
            let k = albedo(a, n.dot(v));
            p.map(|x| x * k)
        }
        Sphere::Diffuse => {
            let e = convert::sample(&cubes.irradiance, n);
            let k = 1.0 / (cubes.irradiance_scale * std::f64::consts::PI);
            e.map(|x| x * k)
        }
    };
    for l in &cubes.lights {
        let f_cos = match s {
            Sphere::Mirror => 0.0,
            Sphere::Ggx(a) => {
                let frame = crate::math::brdf::Frame::new(n);
                let wo = crate::math::brdf::local_view(&frame, v);
                let wi = frame.to_local(l.direction);
                crate::math::split_sum::ggx(a, true).eval_cos(wo, wi)
            }
            Sphere::Diffuse => n.dot(l.direction).max(0.0) / std::f64::consts::PI,
        };
        for (o, e) in out.iter_mut().zip(l.illuminance) {
            *o += f_cos * e;
        }
    }
    out
}

/// Renders the row from `cubes`, the world's directions read through `cube_to_world`.
pub fn render(cubes: &PreviewCubes, cube_to_world: DMat3) -> Picture {
    let world_to_cube = cube_to_world.transpose();
    let mut rgb = Vec::with_capacity((WIDTH * ROW) as usize);
    let mut sphere = Vec::with_capacity((WIDTH * ROW) as usize);
    let first = -SPACING * (SPHERES.len() - 1) as f64 / 2.0;
    for y in 0..ROW {
        for x in 0..WIDTH {
            let d = DVec3::new(
                (x as f64 + 0.5 - WIDTH as f64 / 2.0) / FOCAL,
                (ROW as f64 / 2.0 - y as f64 - 0.5) / FOCAL,
                -1.0,
            )
            .normalize();
            let hit = SPHERES.iter().enumerate().find_map(|(k, s)| {
                let c = DVec3::new(first + SPACING * k as f64, 0.0, -DEPTH);
                let b = d.dot(c);
                let disc = b * b - c.length_squared() + 1.0;
                (disc >= 0.0).then(|| (k, *s, (d * (b - disc.sqrt()) - c).normalize()))
            });
            match hit {
                Some((k, s, n)) => {
                    rgb.push(shade(cubes, s, world_to_cube * n, world_to_cube * -d));
                    sphere.push(k as u8);
                }
                None => {
                    rgb.push(specular_at(&cubes.specular, world_to_cube * d, 0.0));
                    sphere.push(SKY);
                }
            }
        }
    }
    Picture {
        width: WIDTH,
        height: ROW,
        rgb,
        sphere,
    }
}

/// Relative RMS of `got` against `want` per sphere, over its pixels and channels:
/// √(∑(got − want)² / ∑ want²); 0 where both are black, 1 where only `want` is.
pub fn sphere_errors(got: &Picture, want: &Picture) -> Vec<f64> {
    let mut num = vec![0.0; SPHERES.len()];
    let mut den = vec![0.0; SPHERES.len()];
    for ((g, w), s) in got.rgb.iter().zip(&want.rgb).zip(&want.sphere) {
        let Some(k) = (*s != SKY).then_some(*s as usize) else {
            continue;
        };
        for c in 0..3 {
            num[k] += (g[c] - w[c]).powi(2);
            den[k] += w[c] * w[c];
        }
    }
    num.iter()
        .zip(&den)
        .map(|(n, d)| match (*n, *d) {
            (n, _) if !n.is_finite() => 1.0,
            (n, d) if d > 0.0 => (n / d).sqrt(),
            (0.0, _) => 0.0,
            _ => 1.0,
        })
        .collect()
}

/// A preview's check, as the manifest records it.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct PreviewCheck {
    /// Files against intent, relative RMS per sphere, in [`SPHERES`]' order (mirror, GGX 0.1,
    /// 0.3, 0.6, diffuse).
    pub files_vs_intent: Vec<f64>,
    /// The largest of them.
    pub worst: f64,
    /// The picture's exposure (EV): the intent's diffuse sphere at a mean luminance of 0.5.
    pub exposure: f64,
    /// Recipe against reference, relative RMS per sphere of [`reference::COMPARED`] (GGX
    /// 0.1, 0.3, 0.6, diffuse); empty where no source was given.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub recipe_vs_reference: Vec<f64>,
}

/// A rendered preview: the PNG's bytes and its check.
#[derive(Clone, Debug)]
pub struct Preview {
    /// `preview.png`.
    pub png: Vec<u8>,
    /// Files against intent.
    pub check: PreviewCheck,
}

/// The exposure (EV, a tenth's step) that shows `p`'s diffuse sphere at a mean luminance of
/// 0.5; 0 where it is black.
fn exposure(p: &Picture) -> f64 {
    let diffuse = SPHERES
        .iter()
        .position(|s| *s == Sphere::Diffuse)
        .unwrap_or(0) as u8;
    let (mut sum, mut n) = (0.0, 0usize);
    for (c, s) in p.rgb.iter().zip(&p.sphere) {
        if *s == diffuse {
            sum += luminance(*c);
            n += 1;
        }
    }
    let mean = sum / n.max(1) as f64;
    match mean > 0.0 && mean.is_finite() {
        true => ((0.5 / mean).log2() * 10.0).round() / 10.0,
        false => 0.0,
    }
}

/// What envlight's reference sees of a probe: the map its cubes were baked from (the
/// residual, where lights were separated) and the separated lights.
#[derive(Clone, Copy)]
pub struct Source<'a> {
    /// The map as baked, in its file's frame.
    pub map: &'a EnvMap,
    /// The lights a bake handed to lights.json.
    pub separated: Option<&'a SeparateLights>,
}

/// The reference view of `source` baked by `plan` ([`reference::ReferenceView`]): what
/// [`preview`] compares the recipe with. It needs only the source: a bake computes it while
/// the GPU works.
pub fn reference_view(source: Source<'_>, plan: &BakePlan) -> reference::ReferenceView {
    let cube_to_file = plan.orientation.world_to_file();
    let r = reference::Reference::new(source.map, separated_texels(source.separated, cube_to_file));
    reference::ReferenceView::new(&r)
}

/// The preview of a probe whose files are in `dir`: rendered from them, checked against
/// `intent`, and, given the `reference` ([`reference_view`]), the recipe checked against it
/// (see the module docs).
pub fn preview(
    dir: &Path,
    plan: &BakePlan,
    intent: &PreviewCubes,
    reference: Option<&reference::ReferenceView>,
) -> Result<Preview> {
    let files = PreviewCubes::from_files(dir, plan)?;
    let got = render(&files, plan.cube_to_world);
    let want = render(intent, plan.cube_to_world);
    let errors = sphere_errors(&got, &want);
    let worst = errors.iter().copied().fold(0.0, super::worse);
    let file_to_cube = plan.orientation.world_to_file().transpose();
    let recipe = reference.map(|r| reference::recipe_check(&files, file_to_cube, r));
    let check = PreviewCheck {
        files_vs_intent: errors,
        worst,
        exposure: exposure(&want),
        recipe_vs_reference: recipe
            .as_ref()
            .map(|r| r.errors.clone())
            .unwrap_or_default(),
    };
    let png = picture::png(&got, &check, recipe.as_ref())?;
    Ok(Preview { png, check })
}

/// Separated lights as light texels in the file frame (`cube_to_file` turns their
/// cube-frame directions).
fn separated_texels(
    lights: Option<&SeparateLights>,
    cube_to_file: DMat3,
) -> Vec<crate::math::lights::LightTexel> {
    lights
        .map(|ls| {
            ls.lights
                .iter()
                .map(|l| crate::math::lights::LightTexel {
                    layer: 0,
                    i: 0,
                    j: 0,
                    dir: (cube_to_file * DVec3::from(l.direction)).normalize(),
                    omega: l.solid_angle,
                    radiance: l.radiance.map(|r| r as f32),
                })
                .collect()
        })
        .unwrap_or_default()
}

#[cfg(test)]
mod tests;
