//! Light texels gathered into clusters for the cosine kernel: a few vector sums that carry
//! thousands of light texels to diffuse techniques at a cost bounded by the grid.

use super::{nodes, ExtractOptions, Extraction, LightTexel};
use crate::EnvMap;
use glam::DVec3;

/// Light texels gathered for the cosine kernel (diffuse irradiance): the texels of one cell
/// of a `CLUSTER_GRID` × `CLUSTER_GRID`/2 lat-long grid over the file frame, kept as
/// per-channel vector sums V = Σ L·Ω·ω. Their irradiance max(0, n·V) equals the texels'
/// Σ L·Ω·max(0, n·ω) exactly wherever n's horizon misses the cell (the cosine is linear on
/// either side of it); where it cuts the cell the error is at most the power of the cell's
/// texels times the sine of its angular diameter (`cluster_irradiance`). A handful of
/// clusters thus carries thousands of light texels, so diffuse techniques can extract deeply
/// (`DIFFUSE_RATIO`) at a cost bounded by the grid.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Cluster {
    /// Σ L·Ω·ω per channel (world).
    pub v: [DVec3; 3],
}

pub use crate::abi::lights::{CLUSTER_GRID, DIFFUSE_RATIO};

/// The extraction diffuse techniques use: above `ratio` × the mean luminance, uncapped (the
/// clusters bound the cost, not the texels).
pub fn diffuse_options(ratio: f64) -> ExtractOptions {
    ExtractOptions {
        ratio,
        max_texels: usize::MAX,
        fill: None,
    }
}

/// `ex`'s light texels gathered into the cells of a `grid` × `grid`/2 lat-long grid of
/// their file directions ([`Cluster`]), turned to the world by `file_to_world`; cells in
/// row-major order, each summed in the extraction's order (deterministic).
pub fn clusters(ex: &Extraction, file_to_world: glam::DMat3, grid: u32) -> Vec<Cluster> {
    clusters_of(&ex.lights, file_to_world, grid)
}

/// [`clusters`] of a list of light texels.
pub fn clusters_of(lights: &[LightTexel], file_to_world: glam::DMat3, grid: u32) -> Vec<Cluster> {
    let rows = (grid / 2).max(1);
    let mut cells: std::collections::BTreeMap<(u32, u32), [DVec3; 3]> = Default::default();
    for t in lights {
        let c = crate::math::mapping::Mapping::LatLong.dir_to_coord(t.dir);
        let at = |x: f64, n: u32| ((x * n as f64).floor().max(0.0) as u32).min(n - 1);
        let v = cells
            .entry((at(c.v, rows), at(c.u, grid)))
            .or_insert([DVec3::ZERO; 3]);
        let w = file_to_world * t.dir * t.omega;
        for (s, l) in v.iter_mut().zip(t.radiance) {
            *s += w * l as f64;
        }
    }
    cells.into_values().map(|v| Cluster { v }).collect()
}

/// Σ max(0, n·V) over the clusters: the light texels' irradiance at normal `n`, exact
/// except in cells cut by n's horizon ([`Cluster`]). The float64 twin of `shade.frag`'s
/// `lights_irradiance`.
pub fn cluster_irradiance(clusters: &[Cluster], n: DVec3) -> [f64; 3] {
    let mut e = [0.0; 3];
    for c in clusters {
        for (s, v) in e.iter_mut().zip(c.v) {
            *s += n.dot(v).max(0.0);
        }
    }
    e
}

/// The radiance SH coefficients (bands up to `lmax`, world frame through `file_to_world`)
/// of `ex`'s light texels (of `map`), each by the 2×2 Gauss points the projection uses
/// ([`super::nodes`], [`crate::math::sh::project`]): Σ_t L_t·∫_t Y_lm. The whole map's coefficients less
/// these are the residual's, so a residual needs no projection of its own.
pub fn light_sh(
    map: &EnvMap,
    ex: &Extraction,
    file_to_world: glam::DMat3,
    lmax: u32,
) -> Vec<[f64; 3]> {
    light_sh_of(map, &ex.lights, file_to_world, lmax)
}

/// [`light_sh`] of a list of light texels of `map`.
pub fn light_sh_of(
    map: &EnvMap,
    lights: &[LightTexel],
    file_to_world: glam::DMat3,
    lmax: u32,
) -> Vec<[f64; 3]> {
    let mut c = vec![[0.0; 3]; crate::math::sh::count(lmax)];
    let mut y = vec![0.0; c.len()];
    for t in lights {
        for (d, w) in nodes(map, t, 1) {
            crate::math::sh::basis_into(lmax, file_to_world * d, &mut y);
            for (ck, yk) in c.iter_mut().zip(&y) {
                for (a, l) in ck.iter_mut().zip(t.radiance) {
                    *a += l as f64 * w * yk;
                }
            }
        }
    }
    c
}

/// The GPU's list of clusters: `crate::abi::lights::CLUSTER_VEC4S` vec4s each, (V, 0) per
/// channel.
pub fn cluster_list(clusters: &[Cluster]) -> Vec<[f32; 4]> {
    clusters
        .iter()
        .flat_map(|c| c.v.map(|v| [v.x as f32, v.y as f32, v.z as f32, 0.0]))
        .collect()
}
