//! Split-sum shading (Karis 2013, "Real Shading in Unreal Engine 4") in float64: the twins of
//! `glsl/dfg.comp`, `glsl/prefilter_ggx.comp` and the `TECH_SPLIT_SUM` branch of
//! `glsl/shade.frag`.
//!
//! ∫ f·cos·L dω is split into the product of two integrals, each precomputed:
//! - **Prefiltered radiance** P(r, α) = ∫ L·f·cos dω / ∫ f·cos dω for GGX α, taken with the
//!   normal and the view both equal to the reflected direction r (**n = v = r**: the lobe is
//!   made radially symmetric about r, which loses the stretched reflections of grazing views;
//!   this is the approximation users pay for). At n = v both Smith forms give G = G₁(l), so
//!   one chain serves both. It is built by filtered importance sampling: N Hammersley samples
//!   of the GGX sampler, each read from the source's dual-paraboloid MIP chain at
//!   lod = ½·log2(Ωs/Ωp) + bias ([`super::fis`]), as the ratio Σ w·L / Σ w of the sampler's
//!   weights w = f·cos/pdf. Level k of a dual-paraboloid chain holds α = (k/(levels − 1))²
//!   ([`level_alpha`]); shading reads lod = √α·(levels − 1), trilinear between levels.
//! - **DFG** = ∫ f·cos dω split by Schlick's Fresnel as F₀·A + B: A = ∫ f/F·cos·(1 − Fc),
//!   B = ∫ f/F·cos·Fc, Fc = (1 − v·h)⁵. envlight's materials have F = 1, so shading takes
//!   A + B, the directional albedo; A and B are kept apart for engines that use F₀. The table
//!   is indexed by n·v = i/(size − 1) and √α = j/(size − 1), read bilinearly, and
//!   integrated with the rule of [`super::sh_brdf::project`] (graded panels over the GGX
//!   sampler's unit square, 4 × 4 Gauss–Legendre nodes a panel).

use super::brdf::{local_view, Brdf, Frame};
use super::fis::{lookup, lookup_nearest_mip, lookup_own_half, sample_lod};
use super::mapping::{Coord, Mapping};
use super::mip::Level;
use super::sequence::hammersley;
use super::sh_brdf::{for_each_node, PANELS};
pub use crate::abi::split_sum::MU_MIN;
use glam::DVec3;

/// GGX α held by level `k` of a chain of `levels`: (k/(levels − 1))², 0 at level 0.
pub fn level_alpha(k: u32, levels: u32) -> f64 {
    if levels <= 1 {
        return 0.0;
    }
    let r = k as f64 / (levels - 1) as f64;
    r * r
}

/// The lod at which shading reads α: √α·(levels − 1).
pub fn alpha_lod(alpha: f64, levels: u32) -> f64 {
    alpha.clamp(0.0, 1.0).sqrt() * levels.saturating_sub(1) as f64
}

/// GGX with the given Smith form.
pub fn ggx(alpha: f64, correlated: bool) -> Brdf {
    Brdf::Ggx { alpha, correlated }
}

/// (A, B) for GGX α seen at n·v = `mu` (clamped to [[`MU_MIN`], 1]).
pub fn dfg(alpha: f64, correlated: bool, mu: f64) -> [f64; 2] {
    let mu = mu.clamp(MU_MIN, 1.0);
    let wo = DVec3::new((1.0 - mu * mu).max(0.0).sqrt(), 0.0, mu);
    let mut ab = [0.0; 2];
    for_each_node(&ggx(alpha, correlated), wo, PANELS, |wi, k| {
        let fc = fresnel_c(wo, wi);
        ab[0] += k * (1.0 - fc);
        ab[1] += k * fc;
    });
    ab
}

/// Schlick's (1 − v·h)⁵ for the half vector of `wo` and `wi`.
fn fresnel_c(wo: DVec3, wi: DVec3) -> f64 {
    let h = (wo + wi).normalize_or_zero();
    (1.0 - wo.dot(h).clamp(0.0, 1.0)).powi(5)
}

/// Where a DFG table's entries sit on its axes (n·v across, √α down).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum DfgAxes {
    /// Entry i at i/(size − 1): both ends included, so the mirror, α = 1 and grazing views are
    /// read, not extrapolated by clamping (envlight's own lookups).
    #[default]
    Endpoints,
    /// Entry i at (i + ½)/size: a texture's texel centres, as glTF-IBL-Sampler's LUT is
    /// computed and as glTF viewers read it with a plain texture lookup at (n·v, √α).
    Centres,
}

impl DfgAxes {
    /// Parses "endpoints" or "centres".
    pub fn parse(s: &str) -> Option<DfgAxes> {
        match s {
            "endpoints" => Some(DfgAxes::Endpoints),
            "centres" | "centers" => Some(DfgAxes::Centres),
            _ => None,
        }
    }

    /// The abscissa of entry `i` of `size`.
    pub fn at(self, size: u32, i: u32) -> f64 {
        match self {
            DfgAxes::Endpoints => i as f64 / (size.max(2) - 1) as f64,
            DfgAxes::Centres => (i as f64 + 0.5) / size as f64,
        }
    }
}

/// n·v and α of table entry (i, j) of a table `size` (≥ 2) a side at endpoints
/// ([`DfgAxes::Endpoints`]: n·v = i/(size − 1), √α = j/(size − 1)).
pub fn dfg_axes(size: u32, i: u32, j: u32) -> (f64, f64) {
    dfg_axes_at(size, i, j, DfgAxes::Endpoints)
}

/// n·v and α of table entry (i, j) with the axes `axes`.
pub fn dfg_axes_at(size: u32, i: u32, j: u32, axes: DfgAxes) -> (f64, f64) {
    let r = axes.at(size, j);
    (axes.at(size, i), r * r)
}

/// The table the GPU builds: row j (√α) after row, (A, B) per entry, at endpoints.
pub fn dfg_table(size: u32, correlated: bool) -> Vec<[f64; 2]> {
    dfg_table_at(size, correlated, DfgAxes::Endpoints)
}

/// [`dfg_table`] with the axes `axes`.
pub fn dfg_table_at(size: u32, correlated: bool, axes: DfgAxes) -> Vec<[f64; 2]> {
    let mut out = Vec::with_capacity((size * size) as usize);
    for j in 0..size {
        for i in 0..size {
            let (mu, alpha) = dfg_axes_at(size, i, j, axes);
            out.push(dfg(alpha, correlated, mu));
        }
    }
    out
}

/// A bilinear read of `table` (`size` a side) at n·v = `mu` and α, clamped at the edges.
pub fn dfg_lookup(table: &[[f64; 2]], size: u32, mu: f64, alpha: f64) -> [f64; 2] {
    let last = (size - 1) as f64;
    let p = [
        mu.clamp(0.0, 1.0) * last,
        alpha.clamp(0.0, 1.0).sqrt() * last,
    ];
    let i0 = p.map(|x| (x.floor() as u32).min(size.saturating_sub(2)));
    let f = [p[0] - i0[0] as f64, p[1] - i0[1] as f64];
    let i1 = i0.map(|x| (x + 1).min(size - 1));
    let at = |i: u32, j: u32| table[(j * size + i) as usize];
    let mut out = [0.0; 2];
    for (i, j, w) in [
        (i0[0], i0[1], (1.0 - f[0]) * (1.0 - f[1])),
        (i1[0], i0[1], f[0] * (1.0 - f[1])),
        (i0[0], i1[1], (1.0 - f[0]) * f[1]),
        (i1[0], i1[1], f[0] * f[1]),
    ] {
        let t = at(i, j);
        out[0] += w * t[0];
        out[1] += w * t[1];
    }
    out
}

/// One FIS sample of a prefilter level ([`prefilter`]'s rule): at n = v the sample's direction
/// in the texel's frame, its weight and its density depend on the level alone, so the GPU pass
/// reads them from a table instead of sampling GGX again in every texel.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PrefilterSample {
    /// The direction in the frame of the texel's r (z along r).
    pub wi: DVec3,
    /// The sampler's weight f·cos/pdf.
    pub weight: f64,
    /// The lod before the direction's texel term: ½·log2(1/(N·pdf)) + bias − log2(2/size),
    /// so that [`super::fis::sample_lod`] is clamp(lod − log2(1 + |d.y|), 0, max lod) at the
    /// sample's world direction d; +∞ where the pdf is 0 (the last level).
    pub lod: f64,
}

/// The samples of a level of GGX `alpha` filtered by `samples` Hammersley samples with lod
/// `bias` from a chain whose level 0 is `src_size` a side: the samples of [`prefilter`] in
/// its order, those below the horizon (which it skips) left out.
pub fn prefilter_samples(
    alpha: f64,
    samples: u32,
    bias: f64,
    src_size: u32,
) -> Vec<PrefilterSample> {
    let brdf = ggx(alpha, false);
    let texel = (2.0 / src_size as f64).log2();
    (0..samples)
        .filter_map(|i| {
            let wi = brdf.sample(DVec3::Z, hammersley(i, samples));
            if wi.z <= 0.0 {
                return None;
            }
            let pdf = brdf.pdf(DVec3::Z, wi);
            let lod = match pdf > 0.0 {
                true => 0.5 * (1.0 / (samples as f64 * pdf)).log2() + bias - texel,
                false => f64::INFINITY,
            };
            Some(PrefilterSample {
                wi: wi.normalize(),
                weight: brdf.weight(DVec3::Z, wi),
                lod,
            })
        })
        .collect()
}

/// P(r, α): the prefiltered radiance along `r` read from the source chain by `samples` FIS
/// samples with lod `bias` (see the module docs). α = 0 is one bilinear read at lod 0.
pub fn prefilter(chain: &[Level], alpha: f64, r: DVec3, samples: u32, bias: f64) -> [f64; 3] {
    prefilter_read(chain, alpha, r, samples, bias, false).0
}

/// [`prefilter`], each sample read from the level nearest its lod where `nearest_mip`
/// (`PrefilterOptions::nearest_mip`, [`super::fis::lookup_nearest_mip`]), with the number of
/// samples whose lod lies within 1e-4 of a tie between two levels (where float32 may pick the
/// other one; 0 for trilinear reads, which are continuous in the lod).
pub fn prefilter_read(
    chain: &[Level],
    alpha: f64,
    r: DVec3,
    samples: u32,
    bias: f64,
    nearest_mip: bool,
) -> ([f64; 3], u32) {
    if alpha <= 0.0 {
        return (lookup(chain, r, 0.0), 0);
    }
    let frame = Frame::new(r);
    let brdf = ggx(alpha, false);
    let size = chain[0].size;
    let max_lod = (chain.len() - 1) as f64;
    let (mut sum, mut total, mut ties) = ([0.0; 3], 0.0, 0);
    for i in 0..samples {
        let wi = brdf.sample(DVec3::Z, hammersley(i, samples));
        if wi.z <= 0.0 {
            continue;
        }
        let w = brdf.weight(DVec3::Z, wi);
        let d = frame.to_world(wi).normalize();
        let lod = sample_lod(brdf.pdf(DVec3::Z, wi), samples, d, size, bias, max_lod);
        let l = match nearest_mip {
            true => {
                ties += u32::from(lod < max_lod && ((lod - lod.floor()) - 0.5).abs() < 1e-4);
                lookup_nearest_mip(chain, d, lod)
            }
            false => lookup(chain, d, lod),
        };
        for c in 0..3 {
            sum[c] += w * l[c];
        }
        total += w;
    }
    let mean = match total > 0.0 {
        true => sum.map(|s| s / total),
        false => [0.0; 3],
    };
    (mean, ties)
}

/// The direction of texel (i, j) of `layer` of a dual paraboloid `size` a side, extended past
/// the rim by the same formula (those texels continue the other half, so bilinear reads at
/// the rim blend neighbours, not zeros).
pub fn texel_dir(size: u32, layer: u32, i: u32, j: u32) -> DVec3 {
    let s = (i as f64 + 0.5) / size as f64 * 2.0 - 1.0;
    let t = (j as f64 + 0.5) / size as f64 * 2.0 - 1.0;
    let q = s * s + t * t;
    let y = (1.0 - q) / (1.0 + q);
    DVec3::new(
        2.0 * s / (1.0 + q),
        if layer == 0 { y } else { -y },
        2.0 * t / (1.0 + q),
    )
    .normalize()
}

/// The prefiltered cube a bake writes: `levels` levels of a `size`-side cube from `chain`, by
/// the same rule (texel centres' directions as [`Mapping::Cube`] maps them).
pub fn prefiltered_cube(
    chain: &[Level],
    size: u32,
    levels: u32,
    samples: LevelSamples,
    bias: f64,
) -> Vec<Vec<[f64; 3]>> {
    (0..levels)
        .map(|k| {
            let s = level_size(size, k);
            let alpha = level_alpha(k, levels);
            let n = samples.at(size, k);
            let mut texels = Vec::with_capacity((6 * s * s) as usize);
            for layer in 0..6 {
                for j in 0..s {
                    for i in 0..s {
                        let d = Mapping::Cube.coord_to_dir(Coord {
                            layer,
                            u: (i as f64 + 0.5) / s as f64,
                            v: (j as f64 + 0.5) / s as f64,
                        });
                        texels.push(prefilter(chain, alpha, d, n, bias));
                    }
                }
            }
            texels
        })
        .collect()
}

/// Texels a layer of a level may hold and still take more than the base samples: a level
/// whose layers are smaller (8² and below) is cheap to sample more densely.
pub const ROUGH_TEXELS: u64 = 16 * 16;

/// FIS samples per texel at each level of a prefiltered chain: `base` at every level, more at
/// the roughest. Their texels are few (the chain halves its side a level) while their lobes
/// are the widest, read from the coarsest MIP levels, where a set of `base` Hammersley
/// samples errs most (`bench dynamic` publishes each level's error). A level of side s takes
/// `base`·f, f the largest power of two up to `rough_boost` with s²·f ≤ `ROUGH_TEXELS` (16²):
/// each boosted level's layer costs at most what a 16² layer costs at `base`, so the boost
/// adds at most a few such layers to a chain whose level 1 alone is (side/2)². Capped at
/// `MAX_LEVEL_SAMPLES`. `rough_boost` 1: the same samples at every level.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct LevelSamples {
    /// Samples per texel of every level.
    pub base: u32,
    /// The most times `base` a level takes.
    pub rough_boost: u32,
}

/// The most FIS samples per texel a level takes (llvmpipe ends an invocation's loops after
/// 65 535 steps).
pub const MAX_LEVEL_SAMPLES: u32 = 16384;

impl LevelSamples {
    /// `base` samples at every level.
    pub fn flat(base: u32) -> LevelSamples {
        LevelSamples {
            base,
            rough_boost: 1,
        }
    }

    /// Samples per texel at level `k` of a chain `size` a side at level 0.
    pub fn at(&self, size: u32, k: u32) -> u32 {
        let side = u64::from(level_size(size, k));
        let mut f = 1u32;
        while f.saturating_mul(2) <= self.rough_boost
            && side * side * u64::from(2 * f) <= ROUGH_TEXELS
        {
            f *= 2;
        }
        match f {
            1 => self.base,
            _ => self
                .base
                .saturating_mul(f)
                .min(MAX_LEVEL_SAMPLES.max(self.base)),
        }
    }
}

/// Side of level `k` of a chain whose level 0 is `size`.
pub fn level_size(size: u32, k: u32) -> u32 {
    (size >> k).max(1)
}

/// The prefiltered chain the GPU builds from `chain`: `levels` levels of a `size`-side dual
/// paraboloid, stored as [`Level`]s of weight 1 (so [`lookup_own_half`] reads them).
pub fn prefiltered_chain(
    chain: &[Level],
    size: u32,
    levels: u32,
    samples: LevelSamples,
    bias: f64,
) -> Vec<Level> {
    (0..levels)
        .map(|k| {
            let s = level_size(size, k);
            let alpha = level_alpha(k, levels);
            let n = samples.at(size, k);
            let mut texels = Vec::with_capacity((2 * s * s) as usize);
            for layer in 0..2 {
                for j in 0..s {
                    for i in 0..s {
                        let p = prefilter(chain, alpha, texel_dir(s, layer, i, j), n, bias);
                        texels.push([p[0], p[1], p[2], 1.0]);
                    }
                }
            }
            Level { size: s, texels }
        })
        .collect()
}

/// The chain's kernel f·cos at n = v = r, as a function of the gap g = 1 − r·l (which keeps
/// its digits near the axis): D(h)·G/4 with n·h = √(1 − g/2), and G = 2x/(x + √(α² + (1 − α²)x²))
/// at x = 1 − g, which both Smith forms give at n = v. Zero below the horizon. α is clamped
/// to [`super::brdf::GGX_ALPHA_MIN`] as [`Brdf::eval_cos`] clamps it.
pub fn chain_kernel(alpha: f64, gap: f64) -> f64 {
    let x = 1.0 - gap;
    if x <= 0.0 {
        return 0.0;
    }
    let a2 = {
        let a = alpha.max(super::brdf::GGX_ALPHA_MIN);
        a * a
    };
    // |h_xy|² + α²·h_z² with |h_xy|² = g/2 and h_z² = 1 − g/2.
    let s = 0.5 * gap + a2 * (1.0 - 0.5 * gap);
    let d = a2 / (std::f64::consts::PI * s * s);
    let g = 2.0 * x / (x + (a2 + (1.0 - a2) * x * x).sqrt());
    0.25 * d * g
}

/// ∫ K dω over the sphere for [`chain_kernel`] at α: the normalisation of light sums (the
/// directional albedo at n = v). By the zonal kernel's 1D integral 2π∫K(x) dx, x = 1 − t²,
/// with 2·10⁵ midpoints in t, whose spacing (5·10⁻⁶) is far below the peak's scale in t
/// (about α).
pub fn chain_norm(alpha: f64) -> f64 {
    chain_norm_with(alpha, 200_000)
}

fn chain_norm_with(alpha: f64, n: u32) -> f64 {
    let mut sum = 0.0;
    for q in 0..n {
        let t = (q as f64 + 0.5) / n as f64;
        // dx = 2t dt; t ∈ [0, 1] covers x ∈ [0, 1], the kernel's support.
        sum += chain_kernel(alpha, t * t) * 2.0 * t;
    }
    std::f64::consts::TAU * sum / n as f64
}

/// Split-sum shading at normal `n`, view `v` (towards the eye): P(r, α) from the prefiltered
/// chain times A + B (F = 1) from the DFG table.
pub fn shade(
    prefiltered: &[Level],
    table: &[[f64; 2]],
    table_size: u32,
    alpha: f64,
    n: DVec3,
    v: DVec3,
) -> [f64; 3] {
    let frame = Frame::new(n);
    let wo = local_view(&frame, v);
    let r = (2.0 * n.dot(v) * n - v).normalize();
    let p = lookup_own_half(prefiltered, r, alpha_lod(alpha, prefiltered.len() as u32));
    let ab = dfg_lookup(table, table_size, wo.z, alpha);
    p.map(|x| x * (ab[0] + ab[1]))
}

/// The α a lobe tap reads the chain at: `crate::abi::split_sum::TAP_SCALE`·√(Ωs/4π), Ωs =
/// 1/(taps·pdf) the tap's share of the lobe, at most 1.
pub fn tap_alpha(taps: u32, pdf: f64) -> f64 {
    let omega = 1.0 / (taps as f64 * pdf);
    (crate::abi::split_sum::TAP_SCALE * (omega / (4.0 * std::f64::consts::PI)).sqrt()).min(1.0)
}

/// The "lobe taps" recipe's radiance: `taps` Hammersley points of `brdf`'s sampler for the
/// real normal `n` and view `v`, each read from the chain at [`tap_alpha`] along its
/// direction, weighted by f·cos/pdf; their weighted mean (0 where every tap is below the
/// horizon). Unlike P(r, α) it follows the lobe's stretch, its shift towards the normal and
/// its horizon at grazing views.
pub fn taps_mean(prefiltered: &[Level], brdf: &Brdf, n: DVec3, v: DVec3, taps: u32) -> [f64; 3] {
    let frame = Frame::new(n);
    let wo = local_view(&frame, v);
    let levels = prefiltered.len() as u32;
    let (mut sum, mut total) = ([0.0; 3], 0.0);
    for i in 0..taps {
        let wi = brdf.sample(wo, hammersley(i, taps));
        if wi.z <= 0.0 {
            continue;
        }
        let pdf = brdf.pdf(wo, wi);
        if pdf <= 0.0 {
            continue;
        }
        let w = brdf.weight(wo, wi);
        let d = frame.to_world(wi).normalize();
        let l = lookup_own_half(prefiltered, d, alpha_lod(tap_alpha(taps, pdf), levels));
        for c in 0..3 {
            sum[c] += w * l[c];
        }
        total += w;
    }
    if total > 0.0 {
        sum.map(|x| x / total)
    } else {
        [0.0; 3]
    }
}

/// Split-sum shading by the lobe taps recipe: [`taps_mean`] times A + B (F = 1) from the DFG
/// table; the twin of `shade.frag`'s split_sum with taps ≥ 2 (lights aside).
pub fn shade_taps(
    prefiltered: &[Level],
    table: &[[f64; 2]],
    table_size: u32,
    brdf: &Brdf,
    n: DVec3,
    v: DVec3,
    taps: u32,
) -> [f64; 3] {
    let Brdf::Ggx { alpha, .. } = *brdf else {
        return [0.0; 3];
    };
    let wo = local_view(&Frame::new(n), v);
    let p = taps_mean(prefiltered, brdf, n, v, taps);
    let ab = dfg_lookup(table, table_size, wo.z, alpha);
    p.map(|x| x * (ab[0] + ab[1]))
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    #[test]
    fn chain_kernel_is_the_brdf_at_n_equal_v() {
        for alpha in [0.0, 0.02, 0.1, 0.5, 1.0] {
            for x in [-0.3f64, 0.0, 1e-3, 0.2, 0.7, 0.99, 0.999_99, 1.0] {
                let wi = DVec3::new((1.0 - x * x).max(0.0).sqrt(), 0.0, x);
                for correlated in [true, false] {
                    let want = ggx(alpha, correlated).eval_cos(DVec3::Z, wi);
                    let got = chain_kernel(alpha, 1.0 - x);
                    assert!(
                        (got - want).abs() <= 1e-12 * want.max(1e-300),
                        "α {alpha} x {x}: {got} vs {want}"
                    );
                }
            }
        }
    }

    /// The light sums' normalisation is converged (ten times the nodes move it < 1e-8) and
    /// is the directional albedo at n = v by the 1D rule in θ of `Brdf::eval_cos` (1e-8).
    /// (The DFG table's graded rule gives it only to 1.3e-3 at α 0.3, 2.7e-4 at 0.02.)
    #[test]
    fn chain_norm_is_the_albedo_at_normal_incidence() {
        for alpha in [0.02, 0.08, 0.3, 0.6, 1.0] {
            let n = chain_norm(alpha);
            assert!((n - chain_norm_with(alpha, 2_000_000)).abs() < 1e-8);
            let want = albedo_at_normal(alpha, true);
            assert!((n - want).abs() < 1e-8, "α {alpha}: {n} vs {want}");
        }
    }

    /// ∫ f·cos over the hemisphere by a plain (θ, φ) product rule, independent of the
    /// sampler: the albedo A + B must equal.
    fn albedo_by_angles(alpha: f64, correlated: bool, mu: f64) -> f64 {
        let wo = DVec3::new((1.0 - mu * mu).sqrt(), 0.0, mu);
        let brdf = ggx(alpha, correlated);
        let (nt, np) = (2000, 400);
        let mut s = 0.0;
        for a in 0..nt {
            let th = (a as f64 + 0.5) / nt as f64 * PI / 2.0;
            for b in 0..np {
                let ph = (b as f64 + 0.5) / np as f64 * 2.0 * PI;
                let wi = DVec3::new(th.sin() * ph.cos(), th.sin() * ph.sin(), th.cos());
                s += brdf.eval_cos(wo, wi) * th.sin();
            }
        }
        s * (PI / 2.0 / nt as f64) * (2.0 * PI / np as f64)
    }

    /// ∫ f·cos at normal incidence, where the integrand depends on θ alone: a 1D midpoint
    /// rule of 2·10⁵ nodes, exact to far below the bounds.
    fn albedo_at_normal(alpha: f64, correlated: bool) -> f64 {
        let brdf = ggx(alpha, correlated);
        let n = 200_000;
        let h = PI / 2.0 / n as f64;
        (0..n)
            .map(|k| {
                let th = (k as f64 + 0.5) * h;
                let wi = DVec3::new(th.sin(), 0.0, th.cos());
                brdf.eval_cos(DVec3::Z, wi) * th.sin()
            })
            .sum::<f64>()
            * h
            * 2.0
            * PI
    }

    /// A + B is the albedo, against rules independent of the sampler: the 1D rule at normal
    /// incidence for every α (measured worst 3.1e-4, at α 0.36: bound 5e-4), and the plain
    /// (θ, φ) rule at 60° where the lobe is broad enough for it (bound 5e-4). At grazing
    /// views only `Brdf::albedo` is left to compare with, itself a rule on the sampler's
    /// square whose uniform panels miss narrow tails (1.4e-3 off at α 0.09, normal
    /// incidence, where the 1D rule agrees with this one to 2e-5): bound 2e-3.
    #[test]
    fn dfg_sums_to_the_albedo() {
        for &alpha in &[0.01, 0.09, 0.36, 1.0] {
            for &correlated in &[false, true] {
                let ab = dfg(alpha, correlated, 1.0);
                let exact = albedo_at_normal(alpha, correlated);
                assert!(
                    (ab[0] + ab[1] - exact).abs() < 5e-4,
                    "α {alpha}: {ab:?} vs {exact}"
                );
                if alpha >= 0.36 {
                    let ab = dfg(alpha, correlated, 0.5);
                    let plain = albedo_by_angles(alpha, correlated, 0.5);
                    assert!((ab[0] + ab[1] - plain).abs() < 5e-4, "{ab:?} vs {plain}");
                }
                for &mu in &[0.3, 0.1] {
                    let ab = dfg(alpha, correlated, mu);
                    let wo = DVec3::new((1.0 - mu * mu).sqrt(), 0.0, mu);
                    let want = ggx(alpha, correlated).albedo(wo);
                    let got = ab[0] + ab[1];
                    assert!(
                        (got - want).abs() < 2e-3,
                        "α {alpha} μ {mu}: {got} vs {want}"
                    );
                    assert!(ab[0] >= 0.0 && ab[1] >= 0.0 && got <= 1.0 + 1e-9);
                }
            }
        }
    }

    #[test]
    fn dfg_limits() {
        // A mirror-like lobe at normal incidence: all light comes back (F = 1, G → 1), and
        // the half vector is the normal, so Fc → 0.
        let ab = dfg(1e-4, true, 1.0);
        assert!((ab[0] - 1.0).abs() < 1e-3 && ab[1] < 1e-6, "{ab:?}");
        // Grazing views stay finite and below 1.
        for &alpha in &[1e-4, 0.5, 1.0] {
            let ab = dfg(alpha, false, 0.0);
            assert!(ab.iter().all(|x| x.is_finite() && *x >= 0.0) && ab[0] + ab[1] <= 1.0);
        }
    }

    #[test]
    fn the_table_reads_back_its_entries() {
        let size = 8;
        let t = dfg_table(size, false);
        for (i, j) in [(0, 0), (3, 5), (7, 7)] {
            let (mu, alpha) = dfg_axes(size, i, j);
            let got = dfg_lookup(&t, size, mu, alpha);
            let want = t[(j * size + i) as usize];
            assert!((got[0] - want[0]).abs() < 1e-12 && (got[1] - want[1]).abs() < 1e-12);
        }
    }

    /// The boost takes powers of two up to the cap, only where a layer holds at most
    /// ROUGH_TEXELS / f texels, never below the base nor above MAX_LEVEL_SAMPLES.
    #[test]
    fn rough_levels_take_more_samples() {
        let boosted = LevelSamples {
            base: 64,
            rough_boost: 8,
        };
        let at = |l: LevelSamples, size: u32| (0..8).map(|k| l.at(size, k)).collect::<Vec<_>>();
        assert_eq!(at(boosted, 128), [64, 64, 64, 64, 256, 512, 512, 512]);
        assert_eq!(at(boosted, 100), [64, 64, 64, 64, 256, 512, 512, 512]);
        assert_eq!(at(LevelSamples::flat(64), 128), [64; 8]);
        let odd = LevelSamples {
            base: 100,
            rough_boost: 5,
        };
        assert_eq!(at(odd, 16), [100, 400, 400, 400, 400, 400, 400, 400]);
        let big = LevelSamples {
            base: 10_000,
            rough_boost: 8,
        };
        assert_eq!(big.at(8, 3), MAX_LEVEL_SAMPLES);
        let huge = LevelSamples {
            base: 20_000,
            rough_boost: 8,
        };
        assert_eq!(huge.at(8, 3), 20_000);
    }

    /// The samples the GPU reads from its table reproduce `prefilter` (its samples, weights and lods) on a
    /// chain with detail at every lod, for α from the narrowest level to 1, where the pdf
    /// vanishes at the horizon and a sample's lod is the chain's last.
    #[test]
    fn prefilter_samples_reproduce_the_prefilter() {
        use super::super::envmap::EnvMap;
        use super::super::mapping::Mapping;
        let map = EnvMap::from_fn(Mapping::DualParaboloid, 32, 32, 2, |d| {
            let x = (7.0 * d.x).sin() * (5.0 * d.z).cos();
            [
                1.0 + 0.5 * x,
                1.0 + d.y.max(0.0).powi(8) * 30.0,
                0.2 + d.z * d.z,
            ]
        });
        let chain = super::super::mip::chain(&map);
        let max_lod = (chain.len() - 1) as f64;
        for (alpha, samples, bias) in [(0.0278, 64, 1.0), (0.25, 37, 0.0), (1.0, 256, 1.0)] {
            let table = prefilter_samples(alpha, samples, bias, 32);
            assert!(!table.is_empty() && table.len() <= samples as usize);
            for r in super::super::synth::stress_directions() {
                let frame = Frame::new(r);
                let (mut sum, mut total) = ([0.0; 3], 0.0);
                for t in &table {
                    let d = frame.to_world(t.wi).normalize();
                    let lod = (t.lod - (1.0 + d.y.abs()).log2()).clamp(0.0, max_lod);
                    let l = lookup(&chain, d, lod);
                    (0..3).for_each(|c| sum[c] += t.weight * l[c]);
                    total += t.weight;
                }
                let want = prefilter(&chain, alpha, r, samples, bias);
                for c in 0..3 {
                    let got = sum[c] / total;
                    assert!(
                        (got - want[c]).abs() <= 1e-12 * want[c].abs().max(1.0),
                        "α {alpha} r {r}: {got} against {}",
                        want[c]
                    );
                }
            }
        }
    }

    #[test]
    fn level_rule_round_trips() {
        for k in 0..6 {
            assert!((alpha_lod(level_alpha(k, 6), 6) - k as f64).abs() < 1e-12);
        }
    }

    #[test]
    fn texel_dirs_match_the_mapping_inside_the_disc() {
        use super::super::mapping::Mapping;
        let size = 16;
        for layer in 0..2 {
            for (i, j) in [(8, 8), (3, 9), (12, 2)] {
                let d = texel_dir(size, layer, i, j);
                let c = Mapping::DualParaboloid.dir_to_coord(d);
                assert_eq!(c.layer, layer);
                assert!((c.u * size as f64 - (i as f64 + 0.5)).abs() < 1e-9);
                assert!((c.v * size as f64 - (j as f64 + 0.5)).abs() < 1e-9);
            }
        }
    }
}
