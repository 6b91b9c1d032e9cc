//! Scenes: a TOML file naming the environment, a camera, objects with materials and the
//! technique each material is shaded by, and whether shadows are wanted; and its validation
//! ([`Scene::validate`]). What a render runs for it is [`crate::render::plan()`]'s.

use crate::error::{Error, Result};
pub use crate::math::brdf::Brdf;
pub use crate::math::camera::{Camera, Frame, Projection, Shape};
use crate::math::Orientation;
use crate::passes::gbuffer::{object_record, ObjectRecord, Shading};
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

mod needs;
mod validate;

pub use needs::MapShape;

/// Defaults of a scene's settings and of the command line's options, each where it lives.
pub mod defaults {
    pub use crate::math::fis::{
        DEFAULT_BIAS as FIS_BIAS, DEFAULT_BIAS_RESIDUAL as FIS_BIAS_RESIDUAL,
    };
    pub use crate::passes::mc::{
        DEFAULT_PER_FRAME as MC_PER_FRAME, DEFAULT_SAMPLES as MC_SAMPLES, DEFAULT_SEED as MC_SEED,
    };
    /// SH order of diffuse materials.
    pub const SH_ORDER: u32 = 2;
    /// FIS samples per pixel.
    pub const FIS_SAMPLES: u32 = 64;
    /// Side of prefiltered lat-long maps.
    pub const PREFILTERED_SIZE: u32 = 64;
}

/// A scene file.
#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct Scene {
    /// The distant light.
    pub environment: Environment,
    /// The camera.
    pub camera: Camera,
    /// Test environment visibility (V_em) against the scene's objects.
    #[serde(default)]
    pub shadows: bool,
    /// Settings of filtered importance sampling.
    #[serde(default)]
    pub fis: FisSettings,
    /// Settings of split-sum shading.
    #[serde(default)]
    pub split_sum: SplitSumSettings,
    /// Settings of the Monte Carlo reference.
    #[serde(default)]
    pub mc: McSettings,
    /// The objects.
    pub objects: Vec<SceneObject>,
}

/// The environment map and how to read it.
#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct Environment {
    /// The file, relative to the scene file.
    pub file: PathBuf,
    /// Its mapping (`latlong`, `angular`, `cube`, `dual-paraboloid`); inferred when absent.
    #[serde(default)]
    pub mapping: Option<String>,
    /// Mirror the file left–right.
    #[serde(default)]
    pub flip_u: bool,
    /// Turn it upside down.
    #[serde(default)]
    pub flip_v: bool,
    /// Rotate it about +Y, degrees.
    #[serde(default)]
    pub rotate_y: f64,
    /// A scale on its radiance.
    #[serde(default = "one")]
    pub intensity: f64,
    /// Light extraction (`crate::math::lights`): with `extract`, SH irradiance and
    /// prefiltered diffuse materials shade by the residual's SH or irradiance map plus the
    /// light clusters' exact irradiance (a deeper extraction of their own,
    /// `diffuse_light_ratio`), FIS, split-sum and footprint lookups read the residual's
    /// chain plus the light texels, and prefiltered Phong maps are the residual's plus the
    /// light texels under the Phong BRDF; `none` uses the whole map everywhere. SH-BRDF and
    /// MC do not use the lights.
    #[serde(default)]
    pub lights: LightsMode,
    /// FIS, split-sum and footprint lookups: a texel is a light texel above this many times
    /// the map's mean luminance (default 2, `crate::abi::lights::CHAIN_RATIO`).
    #[serde(default)]
    pub light_ratio: Option<f64>,
    /// Most light texels for FIS, split-sum and footprint lookups (default and most 16384,
    /// `crate::abi::lights::CHAIN_MAX_TEXELS`).
    #[serde(default)]
    pub light_texels: Option<u32>,
    /// FIS, split-sum and footprint lookups: rings of texels the light set grows by, the
    /// residual under the lights filled from around them (default 2,
    /// `crate::abi::lights::CHAIN_FILL`, at most `crate::abi::lights::FILL_MAX_RINGS`); 0
    /// clamps the residual at the threshold instead.
    #[serde(default)]
    pub light_fill: Option<u32>,
    /// Diffuse techniques (SH and prefiltered irradiance) extract texels above this many
    /// times the map's mean luminance, uncapped, and sum them by clusters (default 2,
    /// `crate::math::lights::DIFFUSE_RATIO`).
    #[serde(default)]
    pub diffuse_light_ratio: Option<f64>,
    /// How mirror lookups and the background read the map (see [`LookupFilter`]).
    #[serde(default)]
    pub filter: LookupFilter,
}

/// How mirror lookups and the background read the environment.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Deserialize, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum LookupFilter {
    /// Mirrors are filtered over each pixel's footprint (which builds the dual-paraboloid
    /// chain); the background is too wherever the scene builds that chain anyway, else it is
    /// one texel per pixel (a diffuse-only scene builds no chain for its background).
    #[default]
    Auto,
    /// Mirrors and the background are both filtered over the pixel's footprint.
    Footprint,
    /// One texel per pixel: the texel the pixel centre's direction falls in.
    Point,
}

impl Environment {
    /// The light extraction this environment's diffuse techniques ask for.
    pub fn diffuse_extract_options(&self) -> crate::math::lights::ExtractOptions {
        crate::math::lights::diffuse_options(
            self.diffuse_light_ratio
                .unwrap_or(crate::math::lights::DIFFUSE_RATIO),
        )
    }

    /// The light extraction this environment asks for.
    pub fn extract_options(&self) -> crate::math::lights::ExtractOptions {
        let d = crate::math::lights::ExtractOptions::chain();
        crate::math::lights::ExtractOptions {
            ratio: self.light_ratio.unwrap_or(d.ratio),
            max_texels: self.light_texels.map_or(d.max_texels, |n| n as usize),
            fill: match self.light_fill {
                Some(0) => None,
                Some(n) => Some(n),
                None => d.fill,
            },
        }
    }
}

/// What a scene does with the environment's compact bright sources.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Deserialize, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum LightsMode {
    /// Extract them and evaluate them exactly where a technique can.
    #[default]
    Extract,
    /// Leave them in the map.
    None,
}

fn one() -> f64 {
    1.0
}

impl Environment {
    /// Its orientation.
    pub fn orientation(&self) -> Orientation {
        Orientation {
            flip_u: self.flip_u,
            flip_v: self.flip_v,
            rotate_y_degrees: self.rotate_y,
        }
    }
}

/// Settings of filtered importance sampling shared by its materials.
#[derive(Clone, Copy, Debug, Default, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct FisSettings {
    /// Side of each dual-paraboloid half; by default about as many texels as the source.
    #[serde(default)]
    pub size: Option<u32>,
}

/// Settings of split-sum shading shared by its materials (one prefiltered chain serves every
/// GGX roughness and both Smith forms: at n = v they agree).
#[derive(Clone, Copy, Debug, Deserialize, PartialEq, Serialize)]
#[serde(deny_unknown_fields)]
pub struct SplitSumSettings {
    /// Side of the prefiltered chain's level 0; by default the FIS paraboloid's, at most
    /// `crate::abi::split_sum::DEFAULT_SIZE`.
    #[serde(default)]
    pub size: Option<u32>,
    /// Roughness levels: level k holds α = (k/(levels − 1))².
    #[serde(default = "split_levels")]
    pub levels: u32,
    /// FIS samples per prefiltered texel.
    #[serde(default = "split_samples")]
    pub samples: u32,
    /// The most times `samples` the roughest levels take, those whose layers hold 8² texels
    /// or fewer (`crate::math::split_sum::LevelSamples`): 1, the default, keeps `samples` at
    /// every level.
    #[serde(default = "split_rough_boost")]
    pub rough_boost: u32,
    /// Lod bias of those samples; [`DEFAULT_FIS_BIAS`] when absent.
    #[serde(default)]
    pub bias: Option<f64>,
    /// Entries per side of the DFG table.
    #[serde(default = "dfg_size")]
    pub dfg_size: u32,
    /// Reads of the chain per pixel. 1 is Karis' recipe: one read along the reflected
    /// direction at the material's α (the lobe taken at n = v = r). From 2, the "lobe taps"
    /// recipe: the taps follow the real GGX lobe for this normal and view (its stretch, its
    /// shift towards the normal, its horizon), each reading the chain at a narrower α
    /// (`crate::math::split_sum::tap_alpha`), and extracted lights are added under the BRDF
    /// itself instead of the n = v = r kernel.
    #[serde(default = "split_taps")]
    pub taps: u32,
}

fn split_taps() -> u32 {
    crate::abi::split_sum::DEFAULT_TAPS
}

fn split_levels() -> u32 {
    crate::abi::split_sum::DEFAULT_LEVELS
}
fn split_samples() -> u32 {
    crate::abi::split_sum::DEFAULT_SAMPLES
}
fn dfg_size() -> u32 {
    crate::abi::split_sum::DEFAULT_DFG_SIZE
}
fn split_rough_boost() -> u32 {
    1
}

impl Default for SplitSumSettings {
    fn default() -> Self {
        SplitSumSettings {
            size: None,
            levels: split_levels(),
            samples: split_samples(),
            rough_boost: split_rough_boost(),
            bias: None,
            dfg_size: dfg_size(),
            taps: split_taps(),
        }
    }
}

/// Settings of the Monte Carlo reference.
#[derive(Clone, Copy, Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct McSettings {
    /// Combine BRDF and environment sampling (otherwise BRDF sampling alone).
    #[serde(default = "yes")]
    pub mis: bool,
    /// Random seed.
    #[serde(default = "seed")]
    pub seed: u32,
    /// Samples per pixel per dispatch.
    #[serde(default = "per_frame")]
    pub per_frame: u32,
}

fn yes() -> bool {
    true
}
fn seed() -> u32 {
    defaults::MC_SEED
}
fn per_frame() -> u32 {
    defaults::MC_PER_FRAME
}

impl Default for McSettings {
    fn default() -> Self {
        McSettings {
            mis: true,
            seed: seed(),
            per_frame: per_frame(),
        }
    }
}

/// An object: a shape and a material.
#[derive(Clone, Debug, Deserialize, Serialize)]
pub struct SceneObject {
    /// The shape (`shape = "sphere"` or `"plane"` with its fields).
    #[serde(flatten)]
    pub shape: Shape,
    /// Its material.
    pub material: Material,
}

/// A material: a BRDF, a colour and a technique.
#[derive(Clone, Debug, Deserialize, Serialize)]
pub struct Material {
    /// The BRDF and its parameters.
    #[serde(flatten)]
    pub kind: Brdf,
    /// Albedo (diffuse) or specular colour (glossy), RGB.
    #[serde(default = "white")]
    pub albedo: [f64; 3],
    /// How it is shaded; by default `lookup` for mirrors, `sh` for diffuse, `fis` otherwise.
    #[serde(default)]
    pub technique: Option<Technique>,
}

fn white() -> [f64; 3] {
    [1.0; 3]
}

/// The default lod bias of filtered importance sampling: 0 reads the level whose texel
/// matches each sample's solid angle (`cargo xtask lab fis` sweeps the bias against Monte
/// Carlo; docs/fis/).
pub const DEFAULT_FIS_BIAS: f64 = defaults::FIS_BIAS;

/// The default lod bias of filtered importance sampling where it reads the residual of
/// extracted lights (see [`defaults::FIS_BIAS_RESIDUAL`]).
pub const DEFAULT_FIS_BIAS_RESIDUAL: f64 = defaults::FIS_BIAS_RESIDUAL;

/// How a material is shaded.
#[derive(Clone, Copy, Debug, Deserialize, PartialEq, Serialize)]
#[serde(tag = "kind", rename_all = "lowercase", deny_unknown_fields)]
pub enum Technique {
    /// One lookup of the reflected direction (mirrors).
    Lookup,
    /// Filtered importance sampling.
    Fis {
        /// Samples per pixel.
        #[serde(default = "fis_samples")]
        samples: u32,
        /// Lod bias; when absent [`DEFAULT_FIS_BIAS`], or [`DEFAULT_FIS_BIAS_RESIDUAL`]
        /// where the lights are extracted and the samples read the residual.
        #[serde(default)]
        bias: Option<f64>,
        /// Rotate the sample set per pixel (noise instead of banding).
        #[serde(default)]
        rotate: bool,
    },
    /// SH irradiance (diffuse only).
    Sh {
        /// Highest band, 0 to 8.
        #[serde(default = "sh_order")]
        order: u32,
    },
    /// A prefiltered lat-long map: irradiance (diffuse) or the Phong lobe (phong).
    Prefiltered {
        /// Width of the map.
        #[serde(default = "prefiltered_size")]
        size: u32,
    },
    /// SH shading of the BRDF (Kautz, Sloan & Snyder 2002): the BRDF's SH vector per view of
    /// a paraboloid grid, rotated to world space per pixel, against the environment's SH.
    #[serde(rename = "sh_brdf")]
    ShBrdf {
        /// Highest band, 0 to 8.
        #[serde(default = "sh_brdf_order")]
        order: u32,
        /// Views per side of the grid (2 to 64).
        #[serde(default = "sh_brdf_grid")]
        grid: u32,
        /// A Hanning window of this width in bands on the environment's coefficients, against
        /// ringing (Sloan 2008); none when absent.
        #[serde(default)]
        window: Option<f64>,
    },
    /// Split-sum (Karis 2013): one read of a prefiltered GGX chain times the DFG table
    /// (GGX only; see `crate::math::split_sum` for the n = v = r approximation).
    #[serde(rename = "split_sum")]
    SplitSum,
    /// The Monte Carlo reference.
    Mc {
        /// Samples per pixel.
        #[serde(default = "mc_samples")]
        samples: u32,
        /// Stop once the relative error estimate is below this.
        #[serde(default)]
        error: Option<f64>,
    },
}

fn fis_samples() -> u32 {
    defaults::FIS_SAMPLES
}
fn sh_order() -> u32 {
    defaults::SH_ORDER
}
fn sh_brdf_order() -> u32 {
    crate::abi::SH_MAX_LMAX
}
fn sh_brdf_grid() -> u32 {
    crate::abi::sh_brdf::DEFAULT_GRID
}
fn prefiltered_size() -> u32 {
    defaults::PREFILTERED_SIZE
}
fn mc_samples() -> u32 {
    defaults::MC_SAMPLES
}

impl Technique {
    /// Its name in scene files.
    pub fn name(&self) -> &'static str {
        match self {
            Technique::Lookup => "lookup",
            Technique::Fis { .. } => "fis",
            Technique::Sh { .. } => "sh",
            Technique::Prefiltered { .. } => "prefiltered",
            Technique::Mc { .. } => "mc",
            Technique::ShBrdf { .. } => "sh_brdf",
            Technique::SplitSum => "split_sum",
        }
    }
}

impl Material {
    /// The technique, explicit or by default.
    pub fn technique(&self) -> Technique {
        self.technique.unwrap_or(match self.kind {
            Brdf::Mirror => Technique::Lookup,
            Brdf::Lambert => Technique::Sh {
                order: defaults::SH_ORDER,
            },
            _ => Technique::Fis {
                samples: defaults::FIS_SAMPLES,
                bias: None,
                rotate: false,
            },
        })
    }

    /// How the shade pass shades it, its data (SH coefficients, a prefiltered map) at
    /// `data_offset` and an SH-BRDF table at `table_offset`, before a render adds extracted
    /// lights and split-sum's chain and DFG table.
    pub fn shading(&self, data_offset: u32, table_offset: u32) -> Shading {
        match self.technique() {
            Technique::Lookup => Shading::Lookup,
            Technique::Fis {
                samples,
                bias,
                rotate,
            } => Shading::Fis {
                samples,
                lod_bias: bias.unwrap_or(DEFAULT_FIS_BIAS) as f32,
                rotate,
                lights: None,
            },
            Technique::Sh { order } => Shading::Sh {
                offset: data_offset,
                order,
                lights: false,
            },
            Technique::Prefiltered { size } => Shading::Prefiltered {
                offset: data_offset,
                width: size,
                lights: None,
            },
            Technique::Mc { .. } => Shading::Mc,
            Technique::SplitSum => Shading::SplitSum {
                last_lod: 0.0,
                dfg_offset: 0,
                dfg_size: 0,
                taps: 0,
                lights: None,
            },
            Technique::ShBrdf { order, grid, .. } => Shading::ShBrdf {
                grid,
                offset: data_offset,
                order,
                table: table_offset,
            },
        }
    }
}

impl SceneObject {
    /// Its record for the G-buffer, shade and Monte Carlo passes, shaded as
    /// [`Material::shading`] says with its data at `data_offset`.
    pub fn record(&self, data_offset: u32) -> ObjectRecord {
        let m = &self.material;
        object_record(&self.shape, m.albedo, &m.kind, m.shading(data_offset, 0))
    }
}

/// Most FIS samples per pixel.
pub const MAX_FIS_SAMPLES: u32 = 16384;

impl Scene {
    /// A scene of `objects` seen by `camera`, every other setting at its default, the
    /// environment given to the render directly (its file is a placeholder; set it to write
    /// the scene out).
    pub fn new(camera: Camera, objects: Vec<SceneObject>) -> Scene {
        Scene {
            environment: Environment {
                file: "(in memory)".into(),
                mapping: None,
                flip_u: false,
                flip_v: false,
                rotate_y: 0.0,
                intensity: 1.0,
                lights: LightsMode::default(),
                light_ratio: None,
                light_texels: None,
                light_fill: None,
                diffuse_light_ratio: None,
                filter: LookupFilter::default(),
            },
            camera,
            shadows: false,
            fis: FisSettings::default(),
            split_sum: SplitSumSettings::default(),
            mc: McSettings::default(),
            objects,
        }
    }

    /// Reads and checks a scene file.
    pub fn load(path: &Path) -> Result<Scene> {
        let text = std::fs::read_to_string(path).map_err(|source| Error::Io {
            path: path.to_path_buf(),
            source,
        })?;
        let scene: Scene =
            toml::from_str(&text).map_err(|e| Error::bad_file(path, e.to_string()))?;
        scene.validate().map_err(|m| Error::bad_file(path, m))?;
        Ok(scene)
    }

    /// Parses a scene from TOML text (paths stay relative to the caller's directory).
    pub fn parse(text: &str) -> Result<Scene> {
        let scene: Scene =
            toml::from_str(text).map_err(|e| Error::Invalid(format!("scene: {e}")))?;
        scene.validate().map_err(Error::Invalid)?;
        Ok(scene)
    }
}

/// A glossy sphere (FIS 32) over a diffuse plane (SH by default): the scene the unit tests of
/// the model and the plan parse.
#[cfg(test)]
pub(crate) const GLOSSY_TEST_SCENE: &str = r#"
    [environment]
    file = "sky.exr"
    [camera]
    projection = { kind = "perspective", fov_y = 40.0 }
    eye = [0, 1, 5]
    target = [0, 0, 0]
    width = 64
    height = 48
    [[objects]]
    shape = "sphere"
    center = [0, 0, 0]
    radius = 1
    material = { type = "ggx", alpha = 0.3, technique = { kind = "fis", samples = 32 } }
    [[objects]]
    shape = "plane"
    normal = [0, 1, 0]
    offset = -1
    extent = 5
    material = { type = "diffuse", albedo = [0.5, 0.5, 0.5] }
"#;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses() {
        let s = Scene::parse(GLOSSY_TEST_SCENE).unwrap();
        assert_eq!(s.objects.len(), 2);
        assert_eq!(
            s.objects[0].material.technique(),
            Technique::Fis {
                samples: 32,
                bias: None,
                rotate: false
            }
        );
    }

    #[test]
    fn rejects_what_does_not_apply() {
        let bad = GLOSSY_TEST_SCENE.replace("kind = \"fis\", samples = 32", "kind = \"sh\"");
        let e = Scene::parse(&bad).unwrap_err().to_string();
        assert!(e.contains("object 0") && e.contains("sh"), "{e}");
        // Split-sum's chain and DFG table are GGX's: a diffuse object is refused by name, not
        // left to fail later on an empty DFG table.
        let bad = GLOSSY_TEST_SCENE.replace(
            "albedo = [0.5, 0.5, 0.5] }",
            "albedo = [0.5, 0.5, 0.5], technique = { kind = \"split_sum\" } }",
        );
        assert_ne!(bad, GLOSSY_TEST_SCENE);
        let e = Scene::parse(&bad).unwrap_err().to_string();
        assert!(e.contains("object 1") && e.contains("split_sum"), "{e}");
        let bad = GLOSSY_TEST_SCENE.replace("alpha = 0.3", "alpha = 1.5");
        let e = Scene::parse(&bad).unwrap_err().to_string();
        assert!(e.contains("GGX alpha"), "{e}");
        let bad = GLOSSY_TEST_SCENE.replace("width = 64", "width = 0");
        assert!(Scene::parse(&bad).is_err());
        for (taps, ok) in [(0, false), (1, true), (16, true), (65, false)] {
            let text = format!("{GLOSSY_TEST_SCENE}\n[split_sum]\ntaps = {taps}\n");
            let r = Scene::parse(&text);
            assert_eq!(r.is_ok(), ok, "taps {taps}: {:?}", r.err());
            if !ok {
                let e = r.unwrap_err().to_string();
                assert!(e.contains("taps"), "{e}");
            }
        }
    }
}
