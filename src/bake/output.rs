//! What a bake's files hold for the engine that reads them: the frame its cubes are stored in,
//! how its irradiance is normalised, the presets that fix both for Bevy and for the Khronos
//! glTF-IBL-Sampler, how texels brighter than a format holds are clamped and reported, and the
//! lights a bake can hand an engine separately (`lights.json`).
//!
//! Frames. A bake's cubes, SH and lights are all in one *cube frame*: cube direction `c` (the
//! Vulkan face table) holds the environment's radiance from world direction
//! `cube_to_world · c`. The [`Orientation`] a bake passes to [`super::Baker`] is the user's
//! orientation of the probe file (world → file) composed ([`compose`]) with the preset's
//! cube → world ([`Preset::cube_frame`]).
//! - envlight's own convention: the cube frame is the world frame.
//! - Bevy (`bevy_pbr`'s `environment_map.wesl` samples the cube at `(x, y, −z)` of a world
//!   direction): cube → world is `diag(1, 1, −1)`, so Bevy's lookup sees the world unmirrored.
//! - glTF-IBL-Sampler (its panorama lookup `u = ½ + atan2(z, x)/2π`, `v = acos(y)/π`): the
//!   cube frame is the world turned 90° about +Y, so a panorama's centre column lands on the
//!   cube's +X as in its files, where envlight's world has it at +Z.

use crate::error::{Error, Result};
use crate::io::ktx2::{Ktx2Format, Supercompression};
use crate::math::envmap::luminance;
use crate::math::lights::{group, ExtractOptions, Extraction};
use crate::math::split_sum::DfgAxes;
use crate::math::Orientation;
use crate::{EnvMap, Mapping};
use glam::{DMat3, DVec3};

/// How the irradiance cube is normalised.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Irradiance {
    /// Irradiance E = ∫ L·max(0, n·ω) dω (envlight's own).
    #[default]
    E,
    /// E/π: the outgoing radiance of a white Lambertian surface, which Bevy and glTF viewers
    /// multiply by the albedo.
    EOverPi,
}

impl Irradiance {
    /// Parses "e" or "e-over-pi".
    pub fn parse(s: &str) -> Option<Irradiance> {
        match s {
            "e" => Some(Irradiance::E),
            "e-over-pi" => Some(Irradiance::EOverPi),
            _ => None,
        }
    }

    /// The factor the irradiance cube is multiplied by.
    pub fn scale(self) -> f32 {
        match self {
            Irradiance::E => 1.0,
            Irradiance::EOverPi => std::f32::consts::FRAC_1_PI,
        }
    }
}

/// Engines a preset bakes for.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum Preset {
    /// Bevy's `EnvironmentMapLight` and `Skybox`: cubes stored for its (x, y, −z) lookup,
    /// irradiance E/π, E5B9G9R9 with Zstandard supercompression, a `skybox.ktx2` beside.
    Bevy,
    /// glTF-IBL-Sampler's files: its panorama yaw, Lambertian E/π, RGBA16F, ⌊log2 size⌋
    /// specular levels.
    Khronos,
}

impl Preset {
    /// Parses "bevy" or "khronos".
    pub fn parse(s: &str) -> Option<Preset> {
        match s {
            "bevy" => Some(Preset::Bevy),
            "khronos" => Some(Preset::Khronos),
            _ => None,
        }
    }

    /// The consumer's cube → world matrix as an [`Orientation`] (world → file of a file that
    /// stores world direction `M·c` at `c`).
    pub fn cube_frame(self) -> Orientation {
        match self {
            // diag(1, 1, −1) = reflect x, then turn 180° about +Y.
            Preset::Bevy => Orientation {
                flip_u: true,
                flip_v: false,
                rotate_y_degrees: 180.0,
            },
            Preset::Khronos => Orientation {
                flip_u: false,
                flip_v: false,
                rotate_y_degrees: 90.0,
            },
        }
    }

    /// Irradiance normalisation.
    pub fn irradiance(self) -> Irradiance {
        Irradiance::EOverPi
    }

    /// Texel format of the cubes.
    pub fn texels(self) -> Ktx2Format {
        match self {
            Preset::Bevy => Ktx2Format::E5b9g9r9,
            Preset::Khronos => Ktx2Format::Rgba16f,
        }
    }

    /// Supercompression of the cubes.
    pub fn supercompression(self) -> Supercompression {
        match self {
            Preset::Bevy => Supercompression::Zstd,
            Preset::Khronos => Supercompression::None,
        }
    }

    /// Specular levels for a cube `size` a side, where the consumer fixes them: Khronos'
    /// ⌊log2 size⌋ (its levels run size … 2); Bevy reads any count (lod = perceptual roughness
    /// × (levels − 1), envlight's rule).
    pub fn specular_levels(self, size: u32) -> Option<u32> {
        match self {
            Preset::Bevy => None,
            Preset::Khronos => Some(size.max(2).ilog2()),
        }
    }

    /// Whether the level-0 cube is also written as `skybox.ktx2`.
    pub fn skybox(self) -> bool {
        self == Preset::Bevy
    }

    /// Whether the split-sum table is written with every bake, with `lut.png` beside
    /// `dfg.ktx2` (glTF-IBL-Sampler writes its LUT with every run).
    pub fn lut(self) -> bool {
        self == Preset::Khronos
    }

    /// Where the table's entries sit: glTF-IBL-Sampler's LUT at texel centres.
    pub fn dfg_axes(self) -> DfgAxes {
        match self {
            Preset::Bevy => DfgAxes::Endpoints,
            Preset::Khronos => DfgAxes::Centres,
        }
    }

    /// The table's side where the consumer fixes it (glTF-IBL-Sampler's 256).
    pub fn dfg_size(self) -> Option<u32> {
        match self {
            Preset::Bevy => None,
            Preset::Khronos => Some(256),
        }
    }
}

/// `first` then `second` as one orientation: world → file of `first` applied after the frame
/// change `second` (`first.world_to_file() · second.world_to_file()`). Reflections about x
/// turn a later rotation's sense, so the result is again a flip pair and one turn about +Y.
pub fn compose(first: &Orientation, second: &Orientation) -> Orientation {
    let sign = if second.flip_u { -1.0 } else { 1.0 };
    Orientation {
        flip_u: first.flip_u ^ second.flip_u,
        flip_v: first.flip_v ^ second.flip_v,
        rotate_y_degrees: sign * first.rotate_y_degrees + second.rotate_y_degrees,
    }
}

/// What a clamp to a format took from one cube.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct CubeClamp {
    /// Per level, the share of the level's luminance power (∑ Ω·Y over its texels) that the
    /// clamp removed.
    pub power: Vec<f64>,
    /// Channels lowered to the format's largest value.
    pub channels: usize,
    /// Negative channels raised to 0 (unsigned formats).
    pub negative: usize,
}

impl CubeClamp {
    /// Nothing clamped from `levels` levels.
    pub fn none(levels: usize) -> CubeClamp {
        CubeClamp {
            power: vec![0.0; levels],
            channels: 0,
            negative: 0,
        }
    }

    /// The largest share over the levels.
    pub fn worst(&self) -> f64 {
        self.power.iter().copied().fold(0.0, f64::max)
    }
}

/// Whether a texel of `levels` lies outside what `format` holds (above its largest value, or
/// negative in an unsigned format).
pub fn needs_clamp(format: Ktx2Format, levels: &[Vec<[f32; 4]>]) -> bool {
    let top = format.largest();
    levels
        .iter()
        .flatten()
        .any(|t| (0..3).any(|c| t[c] > top[c] || (format.unsigned() && t[c] < 0.0)))
}

/// Clamps every level of a cube (level k is `size >> k` a side, faces × rows × columns) into
/// `format` and reports the power it removed per level.
pub fn clamp_cube(format: Ktx2Format, size: u32, levels: &mut [Vec<[f32; 4]>]) -> CubeClamp {
    let mut report = CubeClamp::default();
    let top = format.largest();
    let outside = |t: &[f32; 4]| (0..3).any(|c| t[c] > top[c] || (format.unsigned() && t[c] < 0.0));
    for (k, level) in levels.iter_mut().enumerate() {
        // Most levels hold nothing to clamp: one scan, and no power sums.
        if !level.iter().any(outside) {
            report.power.push(0.0);
            continue;
        }
        let s = (size >> k).max(1);
        let before = cube_power(level, s);
        let c = crate::io::ktx2::clamp_levels(format, std::slice::from_mut(level));
        let after = cube_power(level, s);
        report.channels += c.high;
        report.negative += c.negative;
        report.power.push(if before > 0.0 {
            ((before - after) / before).max(0.0)
        } else {
            0.0
        });
    }
    report
}

/// ∑ Ω·Y over a cube level `s` a side.
fn cube_power(level: &[[f32; 4]], s: u32) -> f64 {
    let mut sum = 0.0;
    for face in 0..6 {
        for j in 0..s {
            for i in 0..s {
                let t = level[((face * s + j) * s + i) as usize];
                let y = luminance([t[0] as f64, t[1] as f64, t[2] as f64]);
                sum += y * Mapping::Cube.texel_solid_angle(s, s, i, j);
            }
        }
    }
    sum
}

/// The extraction `--lights separate` uses for a map baked into `format`: envlight's default
/// threshold (32 × the mean luminance), lowered where needed to 1/16 of the format's largest
/// value so that the residual fits (a texel of luminance Y has no channel above Y/0.0722, its
/// blue, < 14·Y), and up to 16384 light texels, as many as a 4k map's sun covers.
pub fn separate_options(map: &EnvMap, format: Ktx2Format) -> ExtractOptions {
    let mean = luminance(map.stats().power) / (4.0 * std::f64::consts::PI);
    let top = format.largest().iter().copied().fold(f32::MAX, f32::min) as f64;
    let d = ExtractOptions::default();
    let ratio = if mean > 0.0 {
        d.ratio.min(top / 16.0 / mean)
    } else {
        d.ratio
    };
    ExtractOptions {
        ratio,
        max_texels: crate::abi::lights::CHAIN_MAX_TEXELS as usize,
        fill: None,
    }
}

/// Lights closer than this (radians) are reported as one.
pub const LIGHT_GROUP_RADIUS: f64 = 0.1;

/// One light a bake hands an engine separately.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct SeparateLight {
    /// Unit direction towards the light, in the cube frame (that of the SH and the cubes).
    pub direction: [f64; 3],
    /// The same direction in the consumer's world frame.
    pub world_direction: [f64; 3],
    /// Solid angle of its texels (sr).
    pub solid_angle: f64,
    /// Mean radiance per channel over that solid angle (the map's units).
    pub radiance: [f64; 3],
    /// Illuminance per channel on a surface facing it: ∑ L·Ω (radiance units × sr).
    pub illuminance: [f64; 3],
    /// Its share of the whole map's luminance power.
    pub share: f64,
}

/// A bake's separated lights (`lights.json`).
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct SeparateLights {
    /// The lights, brightest first.
    pub lights: Vec<SeparateLight>,
    /// ∑ illuminance of the lights over the map's whole power ∑ L·Ω, per channel: what the
    /// cubes left out.
    pub share: [f64; 3],
}

impl SeparateLights {
    /// The lights of `ex` (extracted from `map`, file frame), grouped within
    /// [`LIGHT_GROUP_RADIUS`], in the cube frame of `orientation` (world → file of the cube
    /// frame) and the world frame `cube_to_world` maps it to.
    pub fn new(
        map: &EnvMap,
        ex: &Extraction,
        orientation: &Orientation,
        cube_to_world: DMat3,
    ) -> Result<Self> {
        let file_to_cube = orientation.checked_world_to_file()?.transpose();
        let total = map.stats().power;
        let mut lights = Vec::new();
        let mut sum = [0.0; 3];
        for l in group(map, ex, LIGHT_GROUP_RADIUS) {
            let d = (file_to_cube * DVec3::from(l.direction)).normalize_or_zero();
            let w = (cube_to_world * d).normalize_or_zero();
            if d == DVec3::ZERO || l.solid_angle <= 0.0 {
                return Err(Error::Invalid(
                    "a light without direction or solid angle".into(),
                ));
            }
            for (s, p) in sum.iter_mut().zip(l.power) {
                *s += p;
            }
            lights.push(SeparateLight {
                direction: d.to_array(),
                world_direction: w.to_array(),
                solid_angle: l.solid_angle,
                radiance: l.power.map(|p| p / l.solid_angle),
                illuminance: l.power,
                share: l.share,
            });
        }
        let share = [0, 1, 2].map(|c| {
            if total[c] > 0.0 {
                sum[c] / total[c]
            } else {
                0.0
            }
        });
        Ok(SeparateLights { lights, share })
    }

    /// `lights.json`: the lights, and a glTF `KHR_lights_punctual` directional light per light
    /// (colour the illuminance normalised to its largest channel, intensity that channel),
    /// with a node turning its −Z towards the direction the light travels.
    pub fn to_json(&self) -> serde_json::Value {
        let mut punctual = Vec::new();
        let mut nodes = Vec::new();
        for (k, l) in self.lights.iter().enumerate() {
            let top = l.illuminance.iter().copied().fold(0.0, f64::max);
            let color = l.illuminance.map(|c| if top > 0.0 { c / top } else { 0.0 });
            punctual.push(serde_json::json!({
                "type": "directional",
                "name": format!("envlight light {k}"),
                "color": color,
                "intensity": top,
            }));
            let q = rotation_to(DVec3::from(l.world_direction));
            nodes.push(serde_json::json!({
                "name": format!("envlight light {k}"),
                "rotation": [q.x, q.y, q.z, q.w],
                "extensions": { "KHR_lights_punctual": { "light": k } },
            }));
        }
        serde_json::json!({
            "frame": "direction: the cube frame of the SH and the cubes; world_direction: the \
                      consumer's world frame",
            "share": self.share,
            "lights": self.lights,
            "gltf": {
                "extensionsUsed": ["KHR_lights_punctual"],
                "extensions": { "KHR_lights_punctual": { "lights": punctual } },
                "nodes": nodes,
            },
        })
    }
}

/// The unit quaternion turning −Z to `-towards` (a glTF directional light shines along its
/// node's −Z, away from the light, whose direction `towards` points to).
fn rotation_to(towards: DVec3) -> glam::DQuat {
    glam::DQuat::from_rotation_arc(DVec3::NEG_Z, -towards.normalize())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn compose_is_the_matrix_product() {
        let cases = [
            Orientation {
                flip_u: false,
                flip_v: false,
                rotate_y_degrees: 30.0,
            },
            Orientation {
                flip_u: true,
                flip_v: false,
                rotate_y_degrees: -75.0,
            },
            Orientation {
                flip_u: true,
                flip_v: true,
                rotate_y_degrees: 200.0,
            },
            Orientation {
                flip_u: false,
                flip_v: true,
                rotate_y_degrees: 0.0,
            },
        ];
        for a in &cases {
            for b in cases
                .iter()
                .chain(&[Preset::Bevy.cube_frame(), Preset::Khronos.cube_frame()])
            {
                let want = a.world_to_file() * b.world_to_file();
                let got = compose(a, b).world_to_file();
                assert!(
                    (want - got)
                        .abs()
                        .to_cols_array()
                        .iter()
                        .all(|e| *e < 1e-12),
                    "{a:?} {b:?}"
                );
            }
        }
    }

    #[test]
    fn presets_store_their_consumers_frames() {
        // Bevy: cube direction c holds world (c.x, c.y, −c.z).
        let m = Preset::Bevy.cube_frame().world_to_file();
        let c = DVec3::new(0.3, -0.5, 0.8);
        assert!((m * c - DVec3::new(0.3, -0.5, -0.8)).length() < 1e-12);
        // Khronos: the cube's +X reads the panorama's centre column, envlight's +Z.
        let m = Preset::Khronos.cube_frame().world_to_file();
        assert!((m * DVec3::X - DVec3::Z).length() < 1e-12);
        assert!((m * DVec3::Y - DVec3::Y).length() < 1e-12);
    }

    #[test]
    fn a_light_node_shines_away_from_its_direction() {
        for d in [DVec3::Y, DVec3::NEG_Y, DVec3::new(0.6, 0.0, -0.8), DVec3::Z] {
            let q = rotation_to(d);
            assert!((q * DVec3::NEG_Z + d).length() < 1e-12, "{d}");
        }
    }
}
