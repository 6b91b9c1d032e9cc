//! What a bake decides before it reads a probe. [`BakeSettings`] holds the options as a user
//! gives them, each optional: a bake file (`envlight bake --config`, [`BakeSettings::from_toml`])
//! or a command line, the one laid over the other ([`BakeSettings::over`]). [`BakePlan::new`]
//! resolves them over a preset and the defaults into what the bake does and writes.

use super::output::{compose, separate_options, Irradiance, Preset, SeparateLights};
use super::BakeOptions;
use crate::error::{Error, Result};
use crate::io::ktx2::{Ktx2Format, Supercompression};
use crate::math::lights::{extract_blocks, record_block};
use crate::math::split_sum::DfgAxes;
use crate::math::Orientation;
use crate::EnvMap;
use serde::{Deserialize, Serialize};

/// What a bake does with the map's lights.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum LightsMode {
    /// Extracted and added exactly into the cubes.
    Exact,
    /// Written to lights.json; the cubes hold the residual.
    Separate,
    /// The whole map filtered by SH and FIS.
    Off,
}

impl LightsMode {
    /// Parses "exact", "separate" or "off".
    pub fn parse(s: &str) -> Option<LightsMode> {
        match s {
            "exact" => Some(LightsMode::Exact),
            "separate" => Some(LightsMode::Separate),
            "off" => Some(LightsMode::Off),
            _ => None,
        }
    }
}

/// The files a bake writes.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Container {
    /// KTX2 cubes (and JSON), what engines load.
    Ktx2,
    /// OpenEXR images, a file per cube level.
    Exr,
}

impl Container {
    /// Its name, as a bake file and the manifest write it.
    pub fn name(self) -> &'static str {
        match self {
            Container::Ktx2 => "ktx2",
            Container::Exr => "exr",
        }
    }

    /// Parses "ktx2" or "exr".
    pub fn parse(s: &str) -> Option<Container> {
        match s {
            "ktx2" => Some(Container::Ktx2),
            "exr" => Some(Container::Exr),
            _ => None,
        }
    }
}

/// A bake file's `lights`: true (exact), false (off), or a mode's name.
#[derive(Clone, Copy, Debug, PartialEq, Deserialize)]
#[serde(untagged)]
pub enum LightsKey {
    /// true: exact; false: off.
    On(bool),
    /// "exact", "separate" or "off".
    Mode(LightsMode),
}

/// A bake's options as a user gives them, every one optional (a bake file's keys, unknown
/// ones refused); [`BakePlan::new`] fills the rest from the preset and the defaults.
#[derive(Clone, Debug, Default, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
#[non_exhaustive]
pub struct BakeSettings {
    /// Highest SH band written.
    pub sh_order: Option<u32>,
    /// Irradiance cube face size.
    pub irradiance_size: Option<u32>,
    /// Specular cube face size at level 0.
    pub specular_size: Option<u32>,
    /// Specular levels (level k holds GGX α = (k/(levels − 1))²).
    pub specular_levels: Option<u32>,
    /// FIS samples per specular texel.
    pub samples: Option<u32>,
    /// The files written.
    pub format: Option<Container>,
    /// Their KTX2 texels.
    pub texels: Option<Ktx2Format>,
    /// Write the split-sum DFG table once.
    pub dfg: Option<bool>,
    /// Where the DFG table's entries sit.
    pub dfg_samples: Option<DfgAxes>,
    /// Write each probe's dual-paraboloid MIP chain.
    pub chain: Option<bool>,
    /// What becomes of the lights.
    pub lights: Option<LightsKey>,
    /// Texels per cube level checked against float64 exact filters.
    pub check: Option<u32>,
    /// The engine baked for.
    pub preset: Option<Preset>,
    /// Turn the probe about +Y by this many degrees.
    pub rotate_y: Option<f64>,
    /// Mirror the probe left–right.
    pub flip_u: Option<bool>,
    /// Turn the probe upside down.
    pub flip_v: Option<bool>,
    /// How the irradiance cube is normalised.
    pub irradiance: Option<Irradiance>,
    /// Supercompress the KTX2 levels with Zstandard.
    pub zstd: Option<bool>,
    /// Render each probe's `preview.png` from its files, with its check (on by default).
    pub preview: Option<bool>,
    /// Reduce a source wider or taller than this before baking it (not a bake file's key).
    #[serde(skip)]
    pub max_source_side: Option<u32>,
}

impl BakeSettings {
    /// Reads a bake file's TOML.
    pub fn from_toml(text: &str) -> Result<BakeSettings> {
        toml::from_str(text).map_err(|e| Error::Invalid(format!("not a bake file: {e}")))
    }

    /// These settings where given, `under`'s elsewhere (a command line over a bake file).
    pub fn over(self, under: BakeSettings) -> BakeSettings {
        BakeSettings {
            sh_order: self.sh_order.or(under.sh_order),
            irradiance_size: self.irradiance_size.or(under.irradiance_size),
            specular_size: self.specular_size.or(under.specular_size),
            specular_levels: self.specular_levels.or(under.specular_levels),
            samples: self.samples.or(under.samples),
            format: self.format.or(under.format),
            texels: self.texels.or(under.texels),
            dfg: self.dfg.or(under.dfg),
            dfg_samples: self.dfg_samples.or(under.dfg_samples),
            chain: self.chain.or(under.chain),
            lights: self.lights.or(under.lights),
            check: self.check.or(under.check),
            preset: self.preset.or(under.preset),
            rotate_y: self.rotate_y.or(under.rotate_y),
            flip_u: self.flip_u.or(under.flip_u),
            flip_v: self.flip_v.or(under.flip_v),
            irradiance: self.irradiance.or(under.irradiance),
            zstd: self.zstd.or(under.zstd),
            preview: self.preview.or(under.preview),
            max_source_side: self.max_source_side.or(under.max_source_side),
        }
    }
}

/// Everything a bake decided from its settings and its preset.
#[derive(Clone, Debug, PartialEq)]
#[non_exhaustive]
pub struct BakePlan {
    /// What the GPU computes.
    pub options: BakeOptions,
    /// The files written.
    pub container: Container,
    /// Their KTX2 texels.
    pub texels: Ktx2Format,
    /// Their KTX2 supercompression.
    pub supercompression: Supercompression,
    /// The engine baked for, if any.
    pub preset: Option<Preset>,
    /// World → file of the cube frame: the user's orientation after the preset's frame.
    pub orientation: Orientation,
    /// The preset's cube → world (identity without one).
    pub cube_to_world: glam::DMat3,
    /// How the irradiance cube is normalised.
    pub irradiance: Irradiance,
    /// What becomes of the lights.
    pub lights: LightsMode,
    /// Texels per cube level checked against exact filters (0: none).
    pub check: u32,
    /// Whether the DFG table is written.
    pub dfg: bool,
    /// Where its entries sit.
    pub dfg_axes: DfgAxes,
    /// The largest source side baked as read, where given.
    pub max_source_side: Option<u32>,
    /// Whether each probe gets `preview.png` and its check ([`super::preview`]).
    pub preview: bool,
}

impl BakePlan {
    /// Resolves `s`: each setting given, else the preset's, else the default.
    pub fn new(s: &BakeSettings) -> Result<BakePlan> {
        let preset = s.preset;
        let d = BakeOptions::default();
        let specular_size = s.specular_size.unwrap_or(d.specular_size);
        let lights = match s.lights {
            None | Some(LightsKey::On(true)) => LightsMode::Exact,
            Some(LightsKey::On(false)) => LightsMode::Off,
            Some(LightsKey::Mode(m)) => m,
        };
        let options = BakeOptions {
            sh_order: s.sh_order.unwrap_or(d.sh_order),
            irradiance_size: s.irradiance_size.unwrap_or(d.irradiance_size),
            specular_size,
            specular_levels: s
                .specular_levels
                .or(preset.and_then(|p| p.specular_levels(specular_size)))
                .unwrap_or_else(|| {
                    // 8, or every level a smaller cube has.
                    let most = crate::passes::map::full_mips(specular_size, specular_size);
                    d.specular_levels.min(most)
                }),
            samples: s.samples.unwrap_or(d.samples),
            chain: s.chain == Some(true),
            lights: lights == LightsMode::Exact,
            dfg_size: preset.and_then(|p| p.dfg_size()).unwrap_or(d.dfg_size),
            ..d
        };
        options.validate()?;
        let container = s.format.unwrap_or(Container::Ktx2);
        let texels = s
            .texels
            .unwrap_or_else(|| preset.map_or(Ktx2Format::Rgba32f, |p| p.texels()));
        let zstd = s.zstd == Some(true)
            || preset.is_some_and(|p| p.supercompression() == Supercompression::Zstd);
        let irradiance = s
            .irradiance
            .unwrap_or_else(|| preset.map_or(Irradiance::E, |p| p.irradiance()));
        let dfg_axes = s
            .dfg_samples
            .unwrap_or_else(|| preset.map_or(DfgAxes::Endpoints, |p| p.dfg_axes()));
        let user = Orientation {
            flip_u: s.flip_u == Some(true),
            flip_v: s.flip_v == Some(true),
            rotate_y_degrees: s.rotate_y.unwrap_or(0.0),
        };
        user.validate()
            .map_err(|e| Error::Invalid(format!("rotate_y: {e}")))?;
        let frame = preset.map(|p| p.cube_frame()).unwrap_or_default();
        Ok(BakePlan {
            options,
            container,
            texels,
            supercompression: match zstd {
                true => Supercompression::Zstd,
                false => Supercompression::None,
            },
            preset,
            orientation: compose(&user, &frame),
            cube_to_world: frame.world_to_file(),
            irradiance,
            lights,
            check: s.check.unwrap_or(2),
            dfg: s.dfg == Some(true) || preset.is_some_and(|p| p.lut()),
            dfg_axes,
            max_source_side: s.max_source_side,
            preview: s.preview != Some(false),
        })
    }

    /// What the cubes are baked from: `map` itself, or with separate lights its residual and
    /// the lights `lights.json` holds (extracted in blocks of the light record width, each
    /// light's texels clamped as the format needs, in the plan's cube frame).
    pub fn split_lights(&self, map: EnvMap) -> Result<(EnvMap, Option<SeparateLights>)> {
        match self.lights {
            LightsMode::Separate => {
                let block = record_block(&map, self.options.light_record_width);
                let options = separate_options(&map, self.texels);
                let ex = extract_blocks(&map, &options, block).extraction;
                let lights = SeparateLights::new(&map, &ex, &self.orientation, self.cube_to_world)?;
                Ok((ex.residual, Some(lights)))
            }
            LightsMode::Exact | LightsMode::Off => Ok((map, None)),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Without settings: envlight's own defaults (KTX2 rgba32f, E, exact lights, check 2).
    #[test]
    fn no_settings_give_the_defaults() {
        let p = BakePlan::new(&BakeSettings::default()).unwrap();
        assert_eq!(p.options, BakeOptions::default());
        assert_eq!(
            (p.container, p.texels),
            (Container::Ktx2, Ktx2Format::Rgba32f)
        );
        assert_eq!(
            (p.irradiance, p.lights, p.check),
            (Irradiance::E, LightsMode::Exact, 2)
        );
        assert_eq!((p.supercompression, p.dfg), (Supercompression::None, false));
        assert_eq!(p.orientation, Orientation::default());
    }

    /// A preset fills what the settings leave; a setting given wins over it.
    #[test]
    fn a_preset_fills_what_settings_leave() {
        let bevy = BakeSettings {
            preset: Some(Preset::Bevy),
            ..Default::default()
        };
        let p = BakePlan::new(&bevy).unwrap();
        assert_eq!(p.texels, Preset::Bevy.texels());
        assert_eq!(p.irradiance, Irradiance::EOverPi);
        assert_eq!(p.supercompression, Supercompression::Zstd);
        assert_eq!(p.cube_to_world, Preset::Bevy.cube_frame().world_to_file());
        let mine = BakeSettings {
            texels: Some(Ktx2Format::Rgba16f),
            irradiance: Some(Irradiance::E),
            ..bevy
        };
        let p = BakePlan::new(&mine).unwrap();
        assert_eq!(
            (p.texels, p.irradiance),
            (Ktx2Format::Rgba16f, Irradiance::E)
        );
        let khronos = BakePlan::new(&BakeSettings {
            preset: Some(Preset::Khronos),
            specular_size: Some(256),
            ..Default::default()
        })
        .unwrap();
        assert_eq!(khronos.options.specular_levels, 8);
        assert_eq!((khronos.dfg, khronos.dfg_axes), (true, DfgAxes::Centres));
    }

    /// A bake file's keys, a command line laid over them, and what each refuses.
    #[test]
    fn a_file_under_a_command_line() {
        let file = BakeSettings::from_toml(
            "specular_size = 64\nsamples = 32\nlights = false\nflip_u = true\ntexels = \"bc6h\"\n",
        )
        .unwrap();
        let cli = BakeSettings {
            samples: Some(16),
            lights: Some(LightsKey::Mode(LightsMode::Separate)),
            ..Default::default()
        };
        let p = BakePlan::new(&cli.over(file.clone())).unwrap();
        assert_eq!((p.options.specular_size, p.options.samples), (64, 16));
        assert_eq!(
            (p.lights, p.texels),
            (LightsMode::Separate, Ktx2Format::Bc6h)
        );
        assert!(p.orientation.flip_u);
        assert_eq!(BakePlan::new(&file).unwrap().lights, LightsMode::Off);

        let unknown = BakeSettings::from_toml("colour = 1\n")
            .unwrap_err()
            .to_string();
        assert!(
            unknown.contains("not a bake file") && unknown.contains("colour"),
            "{unknown}"
        );
        let texels = BakeSettings::from_toml("texels = \"rgb9\"")
            .unwrap_err()
            .to_string();
        assert!(
            texels.contains("rgb9") && texels.contains("bc6h"),
            "{texels}"
        );
        let lights = BakeSettings::from_toml("lights = \"most\"")
            .unwrap_err()
            .to_string();
        assert!(lights.contains("lights"), "{lights}");
        let bad = |s: BakeSettings| BakePlan::new(&s).unwrap_err().to_string();
        let size = bad(BakeSettings {
            irradiance_size: Some(0),
            ..Default::default()
        });
        assert!(size.contains("irradiance"), "{size}");
    }
}
