//! The ways a probe's files go wrong in users' pipelines, applied to a baked folder's KTX2
//! files, so that a test or a report can show the preview's check catching each: a cube
//! mirrored (a face's columns reversed, as a tool that flips faces for another convention
//! leaves it), irradiance π× too bright (E stored where E/π is read, or the reverse), and
//! the specular levels in reverse roughness order (each level holding the content of its
//! mirror image in the chain, resampled to its size).

use crate::error::{Error, Result};
use crate::io::ktx2::{decode, encode_with, Ktx2Image};
use crate::math::{convert, Mapping};
use crate::EnvMap;
use std::path::Path;

/// A way files go wrong.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Breakage {
    /// Every face of every specular level mirrored left–right.
    Mirrored,
    /// The irradiance cube's texels π× too large.
    IrradianceTimesPi,
    /// Specular level k holds level (n − 1 − k), resampled.
    LevelsReversed,
}

impl Breakage {
    /// All of them.
    pub const ALL: [Breakage; 3] = [
        Breakage::Mirrored,
        Breakage::IrradianceTimesPi,
        Breakage::LevelsReversed,
    ];

    /// A short name.
    pub fn name(self) -> &'static str {
        match self {
            Breakage::Mirrored => "cube mirrored",
            Breakage::IrradianceTimesPi => "irradiance π× too bright",
            Breakage::LevelsReversed => "levels reversed",
        }
    }

    /// Rewrites the KTX2 file it concerns in `dir` (`specular.ktx2` or `irradiance.ktx2`) in
    /// its own format and supercompression.
    pub fn apply(self, dir: &Path) -> Result<()> {
        let file = match self {
            Breakage::IrradianceTimesPi => dir.join("irradiance.ktx2"),
            _ => dir.join("specular.ktx2"),
        };
        let bytes = std::fs::read(&file).map_err(|source| Error::Io {
            path: file.clone(),
            source,
        })?;
        let t = decode(&bytes)?;
        let size = t.width;
        let side = |k: usize| (size >> k).max(1);
        let levels: Vec<Vec<[f32; 4]>> = match self {
            Breakage::Mirrored => t
                .levels
                .iter()
                .enumerate()
                .map(|(k, level)| {
                    let s = side(k) as usize;
                    (0..level.len())
                        .map(|i| {
                            let (face_row, col) = (i / s, i % s);
                            level[face_row * s + (s - 1 - col)]
                        })
                        .collect()
                })
                .collect(),
            Breakage::IrradianceTimesPi => t
                .levels
                .iter()
                .map(|level| {
                    level
                        .iter()
                        .map(|p| {
                            let k = std::f32::consts::PI;
                            [p[0] * k, p[1] * k, p[2] * k, p[3]]
                        })
                        .collect()
                })
                .collect(),
            Breakage::LevelsReversed => {
                let n = t.levels.len();
                let maps: Vec<EnvMap> = t
                    .levels
                    .iter()
                    .enumerate()
                    .map(|(k, l)| crate::bake::files::cube_image(l, side(k)))
                    .collect();
                (0..n)
                    .map(|k| {
                        let from = &maps[n - 1 - k];
                        let to = EnvMap::from_fn(Mapping::Cube, side(k), side(k), 1, |d| {
                            convert::sample(from, d)
                        });
                        to.texels.iter().map(|p| [p[0], p[1], p[2], 1.0]).collect()
                    })
                    .collect()
            }
        };
        let out = encode_with(
            &Ktx2Image::cube(size, &levels),
            t.format,
            t.supercompression,
        )?;
        crate::io::write_atomic(&file, &out)
    }
}
