//! A baked probe's files as an engine loads them, with their bytes: `sh.json`, the
//! irradiance and specular cubes (KTX2 in the plan's texels and supercompression, clamped
//! into the format with the power clamped away reported; or EXR), the skybox a preset wants,
//! the dual-paraboloid chain where asked, and `lights.json` with separate lights.

use super::output::{clamp_cube, needs_clamp, CubeClamp, SeparateLights};
use super::plan::{BakePlan, Container};
use super::Baked;
use crate::error::{Error, Result};
use crate::io::ktx2::{self, Ktx2Format, Ktx2Image};
use crate::{EnvMap, Mapping};
use serde::{Deserialize, Serialize};
use std::borrow::Cow;
use std::path::{Path, PathBuf};

/// What clamping into the texel format took from one probe's cubes.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Clamps {
    /// The irradiance cube's.
    pub irradiance: CubeClamp,
    /// The specular cube's, per level.
    pub specular: CubeClamp,
}

impl Clamps {
    /// The largest share of a level's power clamped away.
    pub fn worst(&self) -> f64 {
        self.irradiance.worst().max(self.specular.worst())
    }
}

/// One probe's files: each path (in the folder given) with its bytes, and what clamping took
/// (None where nothing was clamped or the format holds every value).
#[derive(Clone, Debug)]
pub struct ProbeFiles {
    /// (path, bytes), in the order a bake writes them.
    pub files: Vec<(PathBuf, Vec<u8>)>,
    /// What clamping took.
    pub clamped: Option<Clamps>,
}

/// The files of probe `baked` in folder `dir` as `plan` says, with `lights` where the plan
/// separates them; nothing is written (EXR files pass through a temporary file in `dir`,
/// which must exist).
pub fn probe_files(
    dir: &Path,
    baked: &Baked,
    plan: &BakePlan,
    lights: Option<&SeparateLights>,
) -> Result<ProbeFiles> {
    let sh = json(&baked.sh.to_json())?;
    let mut made = match plan.container {
        Container::Ktx2 => ktx2_files(dir, baked, plan)?,
        Container::Exr => ProbeFiles {
            files: exr_files(dir, baked, plan)?,
            clamped: None,
        },
    };
    made.files.insert(0, (dir.join("sh.json"), sh.into_bytes()));
    if let Some(l) = lights {
        let lights = json(&l.to_json())?;
        made.files
            .push((dir.join("lights.json"), lights.into_bytes()));
    }
    Ok(made)
}

/// `value` as pretty JSON.
fn json<T: Serialize>(value: &T) -> Result<String> {
    serde_json::to_string_pretty(value)
        .map_err(|e| Error::Invalid(format!("a probe's JSON could not be written: {e}")))
}

/// A cube level's RGBA texels as an [`EnvMap`] (alpha dropped).
pub(crate) fn cube_image(texels: &[[f32; 4]], size: u32) -> EnvMap {
    EnvMap::new(
        Mapping::Cube,
        size,
        size,
        texels.iter().map(|t| [t[0], t[1], t[2]]).collect(),
    )
}

/// A probe's KTX2 files: irradiance and specular cubes clamped into the texel format (the
/// power clamped away reported), the skybox where the preset wants one, the chain.
fn ktx2_files(dir: &Path, baked: &Baked, plan: &BakePlan) -> Result<ProbeFiles> {
    let o = &plan.options;
    let scale = plan.irradiance.scale();
    // Copies only where the texels change (a copy of a 256² cube's fresh pages is a few ms).
    let mut irradiance: Cow<[Vec<[f32; 4]>]> = match scale {
        1.0 => Cow::Borrowed(std::slice::from_ref(&baked.irradiance)),
        _ => Cow::Owned(vec![baked
            .irradiance
            .iter()
            .map(|t| [t[0] * scale, t[1] * scale, t[2] * scale, t[3]])
            .collect()]),
    };
    let mut specular = Cow::Borrowed(&baked.specular[..]);
    let clamp = |levels: &mut Cow<[Vec<[f32; 4]>]>, size| match needs_clamp(plan.texels, levels) {
        true => clamp_cube(plan.texels, size, levels.to_mut()),
        false => CubeClamp::none(levels.len()),
    };
    let clamps = Clamps {
        irradiance: clamp(&mut irradiance, o.irradiance_size),
        specular: clamp(&mut specular, o.specular_size),
    };
    let clamped = clamps.irradiance.channels
        + clamps.irradiance.negative
        + clamps.specular.channels
        + clamps.specular.negative
        > 0;
    let cube = |levels: &[Vec<[f32; 4]>], size| -> Result<Vec<u8>> {
        ktx2::encode_with(
            &Ktx2Image::cube(size, levels),
            plan.texels,
            plan.supercompression,
        )
    };
    let mut files = vec![
        (
            dir.join("irradiance.ktx2"),
            cube(&irradiance, o.irradiance_size)?,
        ),
        (dir.join("specular.ktx2"), cube(&specular, o.specular_size)?),
    ];
    if plan.preset.is_some_and(|p| p.skybox()) {
        files.push((
            dir.join("skybox.ktx2"),
            cube(&specular[..1], o.specular_size)?,
        ));
    }
    if let Some(first) = baked.chain.first() {
        // Premultiplied with a weight that reaches 4 at the poles: float32, so that
        // neither a sun nor the weight is refused or rounded.
        let side = ((first.len() / 2) as f64).sqrt() as u32;
        let chain = Ktx2Image {
            width: side,
            height: side,
            faces: 1,
            layers: 2,
            levels: &baked.chain,
        };
        files.push((
            dir.join("chain.ktx2"),
            ktx2::encode_with(&chain, Ktx2Format::Rgba32f, plan.supercompression)?,
        ));
    }
    Ok(ProbeFiles {
        files,
        clamped: clamped.then_some(clamps),
    })
}

/// A probe's EXR files (float32: nothing is clamped).
fn exr_files(dir: &Path, baked: &Baked, plan: &BakePlan) -> Result<Vec<(PathBuf, Vec<u8>)>> {
    let o = &plan.options;
    let mut files = Vec::new();
    let tmp = dir.join(format!(".bake-{}.exr", std::process::id()));
    let exr = |map: &EnvMap| -> Result<Vec<u8>> {
        crate::io::save_exr(map, &tmp)?;
        let b = std::fs::read(&tmp).map_err(|source| Error::Io {
            path: tmp.clone(),
            source,
        })?;
        let _ = std::fs::remove_file(&tmp);
        Ok(b)
    };
    let scale = plan.irradiance.scale();
    let irradiance: Vec<[f32; 4]> = baked
        .irradiance
        .iter()
        .map(|t| [t[0] * scale, t[1] * scale, t[2] * scale, t[3]])
        .collect();
    let b = exr(&cube_image(&irradiance, o.irradiance_size))?;
    files.push((dir.join("irradiance.exr"), b));
    for (k, level) in baked.specular.iter().enumerate() {
        let size = (o.specular_size >> k).max(1);
        let b = exr(&cube_image(level, size))?;
        files.push((dir.join(format!("specular.level{k}.exr")), b));
    }
    // The chain's radiance (rgb / weight), a dual-paraboloid map per level.
    for (k, level) in baked.chain.iter().enumerate() {
        let side = ((level.len() / 2) as f64).sqrt() as u32;
        let texels = level
            .iter()
            .map(|t| {
                let w = if t[3] > 0.0 { 1.0 / t[3] } else { 0.0 };
                [t[0] * w, t[1] * w, t[2] * w]
            })
            .collect();
        let map = EnvMap::new(Mapping::DualParaboloid, side, side, texels);
        files.push((dir.join(format!("chain.level{k}.exr")), exr(&map)?));
    }
    Ok(files)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bake::output::Preset;
    use crate::bake::plan::BakeSettings;
    use crate::passes::sh_project::ShCoefficients;

    /// A probe as a bake returns it: a 4² irradiance cube and an 8² specular cube of 4
    /// levels, smooth, with one texel of level 0 at `sun`.
    fn baked(sun: f32) -> Baked {
        let cube = |size: u32, k: usize| -> Vec<[f32; 4]> {
            (0..6 * size * size)
                .map(|i| {
                    let v = 0.5 + 0.01 * (i % 17) as f32 + 0.1 * k as f32;
                    [v, v * 0.8, v * 0.6, 1.0]
                })
                .collect()
        };
        let mut specular: Vec<Vec<[f32; 4]>> = (0..4).map(|k| cube(8 >> k, k)).collect();
        specular[0][5] = [sun, sun, sun, 1.0];
        Baked {
            sh: ShCoefficients {
                lmax: 2,
                coeffs: (0..9).map(|k| [k as f64, 0.5, -0.25]).collect(),
            },
            irradiance: cube(4, 0),
            specular,
            chain: Vec::new(),
            timings: Vec::new(),
        }
    }

    fn plan(s: BakeSettings) -> BakePlan {
        let s = BakeSettings {
            irradiance_size: Some(4),
            specular_size: Some(8),
            specular_levels: Some(4),
            ..s
        };
        BakePlan::new(&s).unwrap()
    }

    fn names(files: &ProbeFiles) -> Vec<String> {
        let name = |p: &PathBuf| p.file_name().unwrap().to_string_lossy().into_owned();
        files.files.iter().map(|(p, _)| name(p)).collect()
    }

    /// KTX2 files in order, readable as KTX2 in the plan's format; a sun past half floats'
    /// range is clamped and reported, and nothing where it fits.
    #[test]
    fn ktx2_files_clamp_what_the_format_cannot_hold() {
        let dir = Path::new("probe");
        let half = plan(BakeSettings {
            texels: Some(Ktx2Format::Rgba16f),
            ..Default::default()
        });
        let made = probe_files(dir, &baked(1e6), &half, None).unwrap();
        assert_eq!(
            names(&made),
            ["sh.json", "irradiance.ktx2", "specular.ktx2"]
        );
        assert!(made.files.iter().all(|(p, _)| p.starts_with(dir)));
        let clamped = made.clamped.expect("the sun is past rgba16f's range");
        assert_eq!(
            (clamped.specular.channels, clamped.irradiance.channels),
            (3, 0)
        );
        assert!(clamped.specular.power[0] > 0.0 && clamped.specular.power[1] == 0.0);
        let (_, specular) = &made.files[2];
        assert_eq!(&specular[..12], b"\xabKTX 20\xbb\r\n\x1a\n");
        let sh: serde_json::Value = serde_json::from_slice(&made.files[0].1).unwrap();
        assert_eq!(sh["order"], 2);
        assert!(probe_files(dir, &baked(1e3), &half, None)
            .unwrap()
            .clamped
            .is_none());
        // rgba32f holds the sun: nothing clamped.
        let full = plan(BakeSettings::default());
        assert!(probe_files(dir, &baked(1e6), &full, None)
            .unwrap()
            .clamped
            .is_none());
    }

    /// A preset's skybox, and EXR's file per level.
    #[test]
    fn presets_and_containers_choose_the_files() {
        let dir = Path::new("probe");
        let bevy = plan(BakeSettings {
            preset: Some(Preset::Bevy),
            ..Default::default()
        });
        let made = probe_files(dir, &baked(2.0), &bevy, None).unwrap();
        assert_eq!(
            names(&made),
            ["sh.json", "irradiance.ktx2", "specular.ktx2", "skybox.ktx2"]
        );
        let tmp = std::env::temp_dir().join(format!("envlight-files-{}", std::process::id()));
        std::fs::create_dir_all(&tmp).unwrap();
        let exr = plan(BakeSettings {
            format: Some(Container::Exr),
            ..Default::default()
        });
        let made = probe_files(&tmp, &baked(2.0), &exr, None).unwrap();
        let want: Vec<String> = ["sh.json", "irradiance.exr"]
            .into_iter()
            .map(String::from)
            .chain((0..4).map(|k| format!("specular.level{k}.exr")))
            .collect();
        assert_eq!(names(&made), want);
        // Nothing is left in the folder (the EXR encoder's temporary file is removed).
        assert_eq!(std::fs::read_dir(&tmp).unwrap().count(), 0);
        let level1 = crate::io::load(
            &{
                let p = tmp.join("level1.exr");
                std::fs::write(&p, &made.files[3].1).unwrap();
                p
            },
            &crate::io::LoadOptions {
                mapping: Some(Mapping::Cube),
                ..Default::default()
            },
        )
        .unwrap();
        assert_eq!((level1.width, level1.texels[0][0]), (4, 0.6));
        std::fs::remove_dir_all(&tmp).unwrap();
    }
}
