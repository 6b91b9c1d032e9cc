//! Prefiltered cubes a user already has (`envlight report --cube FILE …`) (from envlight's
//! bake, glTF-IBL-Sampler, cmft or any tool writing the same conventions) scored as split-sum
//! shading against converged Monte Carlo, beside envlight's own split-sum and lobe-taps
//! renders of the same probe: cubes.md and cubes.csv.
//!
//! A cube is read from its KTX2 or DDS file, turned into the world by its convention's frame
//! and resampled level by level into the dual-paraboloid chain the float64 split-sum twins
//! read (`crate::math::split_sum::shade`, `crate::math::split_sum::shade_taps`):
//! level k holds α = (k/(levels − 1))² in envlight's bake, glTF-IBL-Sampler (roughness =
//! k/(levels − 1)) and Bevy (lod = perceptual roughness × (levels − 1)); cmft's Phong levels
//! are read at the exponent that matches GGX α (`CubeConvention::level_of`).

use crate::bake::output::Preset;
use crate::error::{Error, Result};
use crate::math::brdf::Brdf;
use crate::math::camera::{trace, Camera, Shape};
use crate::math::convert::sample;
use crate::math::mip::Level;
use crate::math::split_sum::{dfg_table, level_alpha, shade, shade_taps, texel_dir};
use crate::math::Mapping;
use crate::render::score::{errors, exact_own_error, exact_truth, scene, sphere_pixels, truth};
use crate::render::Renderer;
use crate::scene::{LightsMode, SplitSumSettings, Technique};
use crate::{EnvMap, Orientation};
use glam::{DMat3, DVec3};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// Whose conventions a cube follows.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CubeConvention {
    /// envlight's own frame (`envlight bake` without a preset).
    Envlight,
    /// glTF-IBL-Sampler's frame (and `envlight bake --preset khronos`).
    Khronos,
    /// Bevy's (x, y, −z) lookup (`envlight bake --preset bevy`).
    Bevy,
    /// cmft's radiance filter (`--lightingModel phongbrdf --glossScale 10 --glossBias 1`,
    /// DDS output): its cube is envlight's mirrored in x, and its levels hold Phong lobes.
    Cmft,
}

/// cmft's `--glossScale` and `--glossBias` the Cmft convention assumes (cmft's defaults).
const CMFT_GLOSS: (f64, f64) = (10.0, 1.0);

impl CubeConvention {
    /// The conventions' names, as [`CubeConvention::parse`] reads them.
    pub const NAMES: [&'static str; 4] = ["envlight", "khronos", "bevy", "cmft"];

    /// The convention `name` names (one of [`CubeConvention::NAMES`]).
    pub fn parse(name: &str) -> Option<CubeConvention> {
        match name {
            "envlight" => Some(CubeConvention::Envlight),
            "khronos" => Some(CubeConvention::Khronos),
            "bevy" => Some(CubeConvention::Bevy),
            "cmft" => Some(CubeConvention::Cmft),
            _ => None,
        }
    }

    fn frame(self) -> Orientation {
        match self {
            CubeConvention::Envlight => Orientation::default(),
            CubeConvention::Khronos => Preset::Khronos.cube_frame(),
            CubeConvention::Bevy => Preset::Bevy.cube_frame(),
            // Measured: a sun at envlight's (0.67, 0.61, −0.42) lands at (−0.66, 0.62, −0.42)
            // in cmft's cube (`--filter none`).
            CubeConvention::Cmft => Orientation {
                flip_u: true,
                flip_v: false,
                rotate_y_degrees: 0.0,
            },
        }
    }

    /// The (fractional) level of a cube of `levels` that holds GGX α. envlight, glTF-IBL-
    /// Sampler and Bevy: √α·(levels − 1). cmft: level k holds the Phong lobe of exponent
    /// p = 2^(10·g + 1) + 1, g = 1 − k/(levels − 1); GGX α is read where p = 1/α², the Phong
    /// lobe whose curvature at its peak is GGX's at n = v = r (GGX ∝ 1/(1 + θh²/α²)² ≈
    /// exp(−θ²/2α²) with θh = θ/2; cos^p θ ≈ exp(−pθ²/2)).
    fn level_of(self, alpha: f64, levels: u32) -> f64 {
        let last = levels.saturating_sub(1) as f64;
        match self {
            CubeConvention::Cmft => {
                let p = 1.0 / alpha.max(1e-3).powi(2);
                let g = (((p - 1.0).max(1e-9)).log2() - CMFT_GLOSS.1) / CMFT_GLOSS.0;
                (1.0 - g.clamp(0.0, 1.0)) * last
            }
            _ => alpha.clamp(0.0, 1.0).sqrt() * last,
        }
    }
}

/// The report's technique name for glTF-IBL-Sampler's cubes.
pub const PEER: &str = "gltf-ibl-sampler";

/// Taps of the lobe taps recipe the cubes are also shaded with.
const TAPS: u32 = 8;

/// Entries per side of the float64 DFG table.
pub const DFG_SIZE: u32 = 32;

/// The cube at `path` (KTX2 or DDS) as a chain of dual-paraboloid levels in the world, level
/// k holding α = (k/(levels − 1))² read from the cube's level [`CubeConvention::level_of`]
/// (lerped between two levels where that is fractional).
pub(crate) fn cube_chain(path: &Path, convention: CubeConvention) -> Result<Vec<Level>> {
    let cube = crate::io::load_cube_levels(path)?;
    let levels = cube.len() as u32;
    if levels < 2 {
        return Err(Error::bad_file(
            path,
            "one level; a prefiltered cube needs 2 levels or more",
        ));
    }
    // world → cube: the frame's matrix maps cube directions into the world.
    let world_to_cube: DMat3 = convention.frame().world_to_file().transpose();
    Ok((0..levels)
        .map(|k| {
            let f = convention
                .level_of(level_alpha(k, levels), levels)
                .clamp(0.0, (levels - 1) as f64);
            let k0 = (f.floor() as usize).min(levels as usize - 1);
            let k1 = (k0 + 1).min(levels as usize - 1);
            let t = f - k0 as f64;
            let size = (2 * (cube[0].width >> k)).max(2);
            let mut out = Vec::with_capacity((2 * size * size) as usize);
            for layer in 0..2 {
                for j in 0..size {
                    for i in 0..size {
                        let d = (world_to_cube * texel_dir(size, layer, i, j)).normalize();
                        let (a, b) = (sample(&cube[k0], d), sample(&cube[k1], d));
                        let v = [0, 1, 2].map(|c| a[c] + t * (b[c] - a[c]));
                        out.push([v[0], v[1], v[2], 1.0]);
                    }
                }
            }
            Level { size, texels: out }
        })
        .collect())
}

/// Each sphere pixel's (index, normal, view) for `cam`.
fn pixel_frames(cam: &Camera) -> Vec<(usize, DVec3, DVec3)> {
    let sphere = [Shape::Sphere {
        center: [0.0; 3],
        radius: 1.0,
    }];
    let mut v = Vec::new();
    for j in 0..cam.height {
        for i in 0..cam.width {
            let (o, d) = cam.ray(i, j);
            if let Some(h) = trace(&sphere, o, d) {
                let p = o + d * h.t;
                v.push(((j * cam.width + i) as usize, p.normalize(), -d));
            }
        }
    }
    v
}

/// The frame split-sum shading from `chain` gives at GGX α: one read along r, or `taps`.
pub(crate) fn shade_frame(
    cam: &Camera,
    chain: &[Level],
    table: &[[f64; 2]],
    alpha: f64,
    taps: u32,
) -> EnvMap {
    let b = Brdf::Ggx {
        alpha,
        correlated: true,
    };
    let mut frame = EnvMap::new(
        Mapping::LatLong,
        cam.width,
        cam.height,
        vec![[0.0; 3]; (cam.width * cam.height) as usize],
    );
    for (k, n, v) in pixel_frames(cam) {
        let c = if taps <= 1 {
            shade(chain, table, DFG_SIZE, alpha, n, v)
        } else {
            shade_taps(chain, table, DFG_SIZE, &b, n, v, taps)
        };
        frame.texels[k] = c.map(|x| x as f32);
    }
    frame
}

/// Each cube with its convention: the one given in the same place, else the last given,
/// else Khronos'.
pub fn with_conventions(
    cubes: &[PathBuf],
    conventions: &[CubeConvention],
) -> Vec<(PathBuf, CubeConvention)> {
    cubes
        .iter()
        .enumerate()
        .map(|(k, p)| {
            let c = conventions.get(k).or(conventions.last());
            (p.clone(), c.copied().unwrap_or(CubeConvention::Khronos))
        })
        .collect()
}

/// The scores of a probe's cubes: (label, α, relative RMS, mean bias) rows, the reference's
/// noise among them.
pub struct CubeScores {
    /// The probe the cubes were made from.
    pub probe: PathBuf,
    /// The sphere's side.
    pub size: u32,
    /// The reference: `None`, the exact texel sums (`render::score::exact_truth`, float64);
    /// `Some(n)`, Monte Carlo of 2n samples a pixel (`render::score::truth`).
    pub reference: Option<u32>,
    /// (label, α, relative RMS, mean bias).
    pub rows: Vec<(String, f64, f64, f64)>,
}

/// Scores the `cubes` (file, convention) of `probe` at GGX α 0.05, 0.1, 0.3, 0.6 on a sphere
/// seen by `cam`, against the exact texel sums (`reference` `None`) or MIS Monte Carlo of
/// 2 × `reference` spp, beside envlight's own split-sum and lobe-taps renders; `progress`
/// hears each score. The last row of each α is the reference's own error (the exact sums'
/// change when their cells are doubled at 48 pixels) or noise (Monte Carlo's standard error).
pub fn score(
    renderer: &Renderer,
    cam: Camera,
    reference: Option<u32>,
    probe: &Path,
    cubes: &[(PathBuf, CubeConvention)],
    progress: &dyn Fn(&str),
) -> Result<CubeScores> {
    let env = crate::io::load(probe, &Default::default())?;
    let chains = cubes
        .iter()
        .map(|(p, c)| cube_chain(p, *c))
        .collect::<Result<Vec<_>>>()?;
    let table = dfg_table(DFG_SIZE, true);
    let pixels = sphere_pixels(&cam);
    let mut rows: Vec<(String, f64, f64, f64)> = Vec::new();
    for alpha in [0.05, 0.1, 0.3, 0.6] {
        let b = Brdf::Ggx {
            alpha,
            correlated: true,
        };
        let split = SplitSumSettings::default();
        let (truth, noise) = match reference {
            Some(n) => truth(renderer, cam, b, None, split, n, &env)?,
            None => {
                let turn = Orientation::default().world_to_file();
                let frame = exact_truth(&cam, b, &env, turn);
                let own = exact_own_error(&cam, b, &env, turn, &frame, 48);
                (frame, own)
            }
        };
        let mut push = |label: String, frame: &EnvMap| {
            let (rms, bias, _) = errors(frame, &truth, &pixels);
            progress(&format!("α {alpha} {label}: {rms:.3e} (bias {bias:+.2e})"));
            rows.push((label, alpha, rms, bias));
        };
        for (taps, lights, label) in [
            (
                1,
                LightsMode::None,
                "envlight render: split-sum (lights in the chain)",
            ),
            (
                TAPS,
                LightsMode::Extract,
                "envlight render: lobe taps 8 (lights extracted)",
            ),
        ] {
            let mut sc = scene(
                cam,
                b,
                Technique::SplitSum,
                None,
                7,
                SplitSumSettings { taps, ..split },
            );
            sc.environment.lights = lights;
            push(label.to_string(), &renderer.render(&sc, &env)?.frame);
        }
        for ((path, conv), chain) in cubes.iter().zip(&chains) {
            let name = path.display();
            // Split-sum only: a cube that holds its sun aliases under a few lobe taps (that
            // recipe wants the lights apart, as `bake --lights separate` writes them).
            let label = format!("{name} ({conv:?}): split-sum");
            push(label, &shade_frame(&cam, chain, &table, alpha, 1));
        }
        let own = match reference {
            Some(_) => "reference noise",
            None => "reference error",
        };
        rows.push((own.into(), alpha, noise, 0.0));
    }
    Ok(CubeScores {
        probe: probe.to_path_buf(),
        size: cam.width,
        reference,
        rows,
    })
}

impl CubeScores {
    /// cubes.csv: a row per score.
    pub fn csv(&self) -> String {
        let mut csv = String::from("label,alpha,relative_rms,mean_bias\n");
        for (l, alpha, rms, bias) in &self.rows {
            let _ = writeln!(csv, "\"{l}\",{alpha},{rms:.5e},{bias:.5e}");
        }
        csv
    }

    /// cubes.md, measured on `device`: a row per cube or render, a column per α.
    pub fn markdown(&self, device: &str) -> String {
        let reference = match self.reference {
            Some(n) => format!(
                "Monte Carlo, 2 × {n} spp MIS (the mean of {} renders; its noise is their \
                 standard error)",
                crate::render::score::REPLICAS
            ),
            None => "the exact texel sums (every texel's ∫ f·cos in float64, nothing sampled; \
                     its own error is its change when its cells are doubled)"
                .to_string(),
        };
        let mut md = format!(
            "# Prefiltered cubes scored against a reference\n\nProbe {}; device {device}; sphere \
             {}² from normal to grazing incidence; reference {reference}. Each cube \
             is read from its file in its convention's frame, level k taken as GGX α = (k/(levels \
             − 1))², and shaded by split-sum (one read along r) times A + B from a float64 DFG \
             table; envlight's own split-sum and lobe-taps ({TAPS} taps) renders of the probe are \
             beside them. Relative RMS over the sphere, \
             mean bias in parentheses.\n\n| cube or render | α 0.05 | α 0.1 | α 0.3 | α 0.6 |\n\
             |---|---|---|---|---|\n",
            self.probe.display(),
            self.size,
        );
        let mut labels: Vec<&str> = Vec::new();
        for (l, ..) in &self.rows {
            if !labels.contains(&l.as_str()) {
                labels.push(l);
            }
        }
        for l in labels {
            let cells: Vec<String> = self
                .rows
                .iter()
                .filter(|r| r.0 == l)
                .map(|r| format!("{:.1}% ({:+.1}%)", 100.0 * r.2, 100.0 * r.3))
                .collect();
            let _ = writeln!(md, "| {l} | {} |", cells.join(" | "));
        }
        md
    }
}

/// A cube glTF-IBL-Sampler made of a probe, with its whole-process seconds.
pub struct PeerCube {
    /// Its GGX samples.
    pub samples: u32,
    /// Wall seconds of its run.
    pub seconds: f64,
    /// The cube as a chain in the world.
    pub(crate) chain: Vec<Level>,
}

impl PeerCube {
    /// The cube of `path` (KTX2 or DDS, in `convention`), made with `samples` in `seconds`.
    pub fn read(
        path: &Path,
        convention: CubeConvention,
        samples: u32,
        seconds: f64,
    ) -> Result<PeerCube> {
        Ok(PeerCube {
            samples,
            seconds,
            chain: cube_chain(path, convention)?,
        })
    }
}
