//! An environment map in memory: linear float RGB texels in one of the four mappings.

use crate::math::mapping::{Coord, Mapping};
use glam::DVec3;

/// An environment map: `layers × height × width` linear RGB texels (layer-major, then rows
/// from the top, then columns from the left).
#[derive(Clone, Debug, PartialEq)]
pub struct EnvMap {
    /// How directions map to texels.
    pub mapping: Mapping,
    /// Width of one layer in texels.
    pub width: u32,
    /// Height of one layer in texels.
    pub height: u32,
    /// The texels.
    pub texels: Vec<[f32; 3]>,
}

/// Statistics over the texels that hold the sphere (see [`EnvMap::for_each_texel`]).
#[derive(Clone, Debug, PartialEq)]
pub struct Stats {
    /// Per-channel minimum over finite texels.
    pub min: [f32; 3],
    /// Per-channel maximum over finite texels.
    pub max: [f32; 3],
    /// Solid-angle-weighted mean radiance, per channel.
    pub mean: [f64; 3],
    /// Maximum Rec. 709 luminance.
    pub max_luminance: f64,
    /// Texels with a NaN channel.
    pub nan: usize,
    /// Texels with an infinite channel.
    pub inf: usize,
    /// Texels with a negative channel.
    pub negative: usize,
    /// Total power ∑ L·dω per channel (W/m² for radiance in W/(m²·sr)).
    pub power: [f64; 3],
}

/// Rec. 709 luminance of linear RGB.
pub fn luminance(c: [f64; 3]) -> f64 {
    let w = crate::abi::constants::LUMINANCE;
    w[0] * c[0] + w[1] * c[1] + w[2] * c[2]
}

impl EnvMap {
    /// The map with every texel that is not a finite, non-negative radiance set to zero, and
    /// how many were: the float64 twin of the resident path's first pass
    /// (`passes::map::Sanitizer`, glsl/sanitize.comp).
    pub fn sanitized(&self) -> (EnvMap, usize) {
        let mut zeroed = 0;
        let texels = self
            .texels
            .iter()
            .map(|t| match t.iter().all(|c| c.is_finite() && *c >= 0.0) {
                true => *t,
                false => {
                    zeroed += 1;
                    [0.0; 3]
                }
            })
            .collect();
        (
            EnvMap::new(self.mapping, self.width, self.height, texels),
            zeroed,
        )
    }

    /// Wraps texels; panics if their count does not match the size (a caller bug).
    pub fn new(mapping: Mapping, width: u32, height: u32, texels: Vec<[f32; 3]>) -> EnvMap {
        assert_eq!(
            texels.len(),
            (width as usize) * (height as usize) * mapping.layers() as usize,
            "texel count does not match {width}x{height}x{}",
            mapping.layers()
        );
        EnvMap {
            mapping,
            width,
            height,
            texels,
        }
    }

    /// Bakes an analytic function (solid-angle-weighted supersampling, `ss × ss` per texel).
    pub fn from_fn(
        mapping: Mapping,
        width: u32,
        height: u32,
        ss: u32,
        f: impl Fn(DVec3) -> [f64; 3] + Sync,
    ) -> EnvMap {
        let texels = crate::math::synth::bake(mapping, width, height, ss, f);
        EnvMap::new(mapping, width, height, texels)
    }

    /// Number of layers.
    pub fn layers(&self) -> u32 {
        self.mapping.layers()
    }

    /// Index of texel (i, j) of `layer` in [`EnvMap::texels`].
    pub fn index(&self, layer: u32, i: u32, j: u32) -> usize {
        ((layer * self.height + j) * self.width + i) as usize
    }

    /// Texel (i, j) of `layer`.
    pub fn texel(&self, layer: u32, i: u32, j: u32) -> [f32; 3] {
        self.texels[self.index(layer, i, j)]
    }

    /// Calls `f(layer, i, j, texel, solid angle)` for every texel that holds part of the
    /// sphere, with the value that stands for it ([`Mapping::integration_source`]): the texels
    /// the mapping reads, and the rim slivers of an angular map. The solid angles sum to 4π.
    pub fn for_each_texel(&self, mut f: impl FnMut(u32, u32, u32, [f32; 3], f64)) {
        let (w, h) = (self.width, self.height);
        if self.mapping == Mapping::LatLong {
            // Every texel is its own source and a row's texels share one solid angle: no
            // per-texel table (a 1k map's would be 12 MB to fault in and fill).
            for j in 0..h {
                let o = self.mapping.texel_solid_angle(w, h, 0, j);
                for i in 0..w {
                    f(0, i, j, self.texel(0, i, j), o);
                }
            }
            return;
        }
        // Solid angles and sources are the same on every layer; find them once per texel.
        let omega = self.mapping.texel_solid_angles(w, h);
        let mut table = Vec::with_capacity((w * h) as usize);
        for j in 0..h {
            for i in 0..w {
                // A texel with no part of the sphere has no source (integration_source would
                // find its solid angle again to say so).
                let o = omega[(j * w + i) as usize];
                table.push(match o > 0.0 || self.mapping.texel_in_domain(w, h, i, j) {
                    true => self
                        .mapping
                        .integration_source(w, h, i, j)
                        .map(|src| (src, o)),
                    false => None,
                });
            }
        }
        for layer in 0..self.layers() {
            for j in 0..h {
                for i in 0..w {
                    if let Some(((si, sj), o)) = table[(j * w + i) as usize] {
                        f(layer, i, j, self.texel(layer, si, sj), o);
                    }
                }
            }
        }
    }

    /// Statistics over the texels this map's mapping reads.
    pub fn stats(&self) -> Stats {
        let mut s = Stats {
            min: [f32::INFINITY; 3],
            max: [f32::NEG_INFINITY; 3],
            mean: [0.0; 3],
            max_luminance: f64::NEG_INFINITY,
            nan: 0,
            inf: 0,
            negative: 0,
            power: [0.0; 3],
        };
        let mut omega_sum = 0.0;
        self.for_each_texel(|_, _, _, t, o| {
            if t.iter().any(|c| c.is_nan()) {
                s.nan += 1;
            } else if t.iter().any(|c| c.is_infinite()) {
                s.inf += 1;
            }
            if t.iter().any(|&c| c < 0.0) {
                s.negative += 1;
            }
            if t.iter().all(|c| c.is_finite()) {
                for (k, &c) in t.iter().enumerate() {
                    s.min[k] = s.min[k].min(c);
                    s.max[k] = s.max[k].max(c);
                    s.power[k] += c as f64 * o;
                }
                s.max_luminance = s.max_luminance.max(luminance(t.map(f64::from)));
                omega_sum += o;
            }
        });
        if omega_sum > 0.0 {
            s.mean = s.power.map(|p| p / omega_sum);
        }
        s
    }

    /// Total power ∑ L·dω per channel over the texels the mapping reads.
    pub fn power(&self) -> [f64; 3] {
        self.stats().power
    }

    /// Direction at the centre of texel (i, j) of `layer`.
    pub fn texel_dir(&self, layer: u32, i: u32, j: u32) -> DVec3 {
        self.mapping
            .coord_to_dir(Mapping::texel_center(self.width, self.height, layer, i, j))
    }

    /// Texture coordinate of a direction in this map.
    pub fn coord(&self, d: DVec3) -> Coord {
        self.mapping.dir_to_coord(d)
    }
}
