//! Light extraction: the compact bright sources of a map (a sun, lamps, the
//! hot cores of softboxes) taken out as a list of texels, each evaluated exactly where a
//! technique integrates them, leaving a residual map whose dynamic range band-limited and
//! filtered techniques handle well.
//!
//! Rule (deterministic, the same on every mapping): a texel holding part of the sphere
//! ([`EnvMap::for_each_texel`], so an angular map's rim slivers count as in every integral)
//! is a light texel when its luminance Y exceeds the threshold τ = `ratio` × the map's mean
//! luminance (power / 4π), raised where needed so that at most `max_texels` texels pass. A
//! light texel keeps L·(1 − τ/Y) and the residual L·τ/Y: the residual is the map with its
//! luminance clamped at τ (chroma kept, so it stays continuous around a light), and lights
//! plus residual equal the map to float32 rounding. A texel's light is its excess over the
//! clamp, spread over the texel as the map spreads its radiance.
//!
//! Filtered sampling wants no plateau in the residual, whose edge its few filtered samples
//! alias: with [`ExtractOptions::fill`] the light set first grows by rings of texels around
//! it (the glow at a softbox's rim, below τ), and the residual under it continues its
//! surroundings (`fill`) instead of the clamp; lights plus residual still equal the map.

mod blocks;
mod clusters;
mod group;

pub use group::{group, Light};

pub use clusters::{
    cluster_irradiance, cluster_list, clusters, clusters_of, diffuse_options, light_sh,
    light_sh_of, Cluster, CLUSTER_GRID, DIFFUSE_RATIO,
};

pub use blocks::{
    block_means, extract_block_lights, extract_blocks, record_block, BlockExtraction, BlockLights,
};

use super::brdf::{local_view, Brdf, Frame};
use super::mapping::Coord;
use crate::math::envmap::luminance;
use crate::EnvMap;
use glam::DVec3;

/// How lights are extracted.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct ExtractOptions {
    /// Threshold over the map's mean luminance.
    pub ratio: f64,
    /// Most light texels kept (the threshold rises to keep to it).
    pub max_texels: usize,
    /// How the residual under the lights is shaped: `None` clamps each light texel's
    /// luminance at the threshold; `Some(d)` first grows the lights by the texels within `d`
    /// of them (where the cap leaves room) and fills the residual under them from the texels
    /// around them (`fill`), so that no plateau edge is left for filtered lookups to alias.
    #[serde(default)]
    pub fill: Option<u32>,
}

impl Default for ExtractOptions {
    fn default() -> Self {
        ExtractOptions {
            ratio: crate::abi::lights::DEFAULT_RATIO,
            max_texels: crate::abi::lights::MAX_TEXELS as usize,
            fill: None,
        }
    }
}

impl ExtractOptions {
    /// The renderer's default for the chain that FIS, split-sum and footprint lookups read
    /// (`crate::abi::lights::CHAIN_RATIO`, `crate::abi::lights::CHAIN_MAX_TEXELS`, the
    /// residual filled under lights grown by `crate::abi::lights::CHAIN_FILL`):
    /// deeper than [`Default`] (the bake's), the texels
    /// summed through a `super::light_tree::LightTree`.
    pub fn chain() -> ExtractOptions {
        ExtractOptions {
            ratio: crate::abi::lights::CHAIN_RATIO,
            max_texels: crate::abi::lights::CHAIN_MAX_TEXELS as usize,
            fill: Some(crate::abi::lights::CHAIN_FILL),
        }
    }
}

/// One light texel: its excess radiance over the residual's clamp.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LightTexel {
    /// Layer, column and row of the texel in the map.
    pub layer: u32,
    /// Column.
    pub i: u32,
    /// Row.
    pub j: u32,
    /// Centre direction (file frame).
    pub dir: DVec3,
    /// Exact solid angle.
    pub omega: f64,
    /// Excess radiance L − residual.
    pub radiance: [f32; 3],
}

/// A map split into light texels and a residual.
#[derive(Clone, Debug)]
pub struct Extraction {
    /// The luminance threshold τ (infinite when nothing was extracted).
    pub threshold: f64,
    /// The light texels, brightest first (ties by position).
    pub lights: Vec<LightTexel>,
    /// The map with its luminance clamped at τ.
    pub residual: EnvMap,
}

/// An extraction's threshold and light texels without its residual map: what a caller that
/// makes the residual itself needs (the clamp rule's residual is [`clamp_residual`] of the
/// map at `threshold`, which a bake applies on the GPU as it converts the source,
/// `passes::Converter::record_split`, or in place, `passes::map::LuminanceClamp`).
#[derive(Clone, Debug)]
pub struct LightSet {
    /// The luminance threshold τ (infinite when nothing was extracted).
    pub threshold: f64,
    /// The light texels, brightest first (ties by position).
    pub lights: Vec<LightTexel>,
}

/// The clamp rule's residual: `map` with every texel of its domain whose luminance Y exceeds
/// `threshold` scaled by τ/Y (in float32, as [`extract`] makes it; texels outside the domain,
/// which no integral reads as their own, keep their values). [`extract`]'s residual, with
/// [`ExtractOptions::fill`] `None`, is this at its threshold. Float64-rule twin of
/// glsl/clamp.comp.
pub fn clamp_residual(map: &EnvMap, threshold: f64) -> EnvMap {
    let mut residual = map.clone();
    if threshold.is_finite() {
        clamp_texels(&mut residual, threshold);
    }
    residual
}

/// [`clamp_residual`] in place.
fn clamp_texels(map: &mut EnvMap, threshold: f64) {
    let (w, h) = (map.width, map.height);
    for layer in 0..map.layers() {
        for j in 0..h {
            for i in 0..w {
                if !map.mapping.texel_in_domain(w, h, i, j) {
                    continue;
                }
                let k = map.index(layer, i, j);
                let l = map.texels[k];
                let y = luminance(l.map(f64::from));
                if y > threshold {
                    let keep = (threshold / y) as f32;
                    map.texels[k] = l.map(|c| c * keep);
                }
            }
        }
    }
}

/// [`extract`]'s threshold and light texels without building its residual (with
/// [`ExtractOptions::fill`] `None`, the residual is [`clamp_residual`] at the threshold).
pub fn extract_lights(map: &EnvMap, opts: &ExtractOptions) -> LightSet {
    if opts.fill.is_some() {
        let ex = extract(map, opts);
        return LightSet {
            threshold: ex.threshold,
            lights: ex.lights,
        };
    }
    let (mean, y_at) = luminances(map);
    split_lights(map, mean, &y_at, opts)
}

/// Extracts the lights of `map`.
pub fn extract(map: &EnvMap, opts: &ExtractOptions) -> Extraction {
    extract_each(map, &[*opts])
        .pop()
        .unwrap_or_else(|| unreachable!())
}

/// [`extract`] by each of `opts`, the map's texels and their solid angles visited once (a
/// bake or render extracting for FIS and for diffuse techniques reads the map once).
pub fn extract_each(map: &EnvMap, opts: &[ExtractOptions]) -> Vec<Extraction> {
    if opts.is_empty() {
        return Vec::new();
    }
    let (mean, y_at) = luminances(map);
    opts.iter().map(|o| split(map, mean, &y_at, o)).collect()
}

/// The map's mean luminance (power / 4π) and the luminance of the value standing for each
/// texel position that holds part of the sphere (NaN elsewhere), by index: one array instead
/// of a list of every texel, which on a 1k map would be 17 MB to fault in; solid angles are
/// found again for the few candidates.
fn luminances(map: &EnvMap) -> (f64, Vec<f64>) {
    let mut power = 0.0;
    let mut y_at = vec![f64::NAN; map.texels.len()];
    map.for_each_texel(|layer, i, j, t, omega| {
        let y = luminance(t.map(f64::from));
        power += y * omega;
        y_at[map.index(layer, i, j)] = y;
    });
    (power / (4.0 * std::f64::consts::PI), y_at)
}

/// A texel position of `map` from its index: (layer, i, j).
fn position(map: &EnvMap, k: usize) -> (u32, u32, u32) {
    let (w, h) = (map.width as usize, map.height as usize);
    ((k / (w * h)) as u32, (k % w) as u32, (k / w % h) as u32)
}

/// Whether every texel of `map`'s mapping is its own integration source (no disc rim).
fn every_texel_its_own(map: &EnvMap) -> bool {
    matches!(
        map.mapping,
        super::mapping::Mapping::LatLong | super::mapping::Mapping::Cube
    )
}

/// One extraction of `map` (mean luminance `mean`, `y_at` the luminance at each position).
fn split(map: &EnvMap, mean: f64, y_at: &[f64], opts: &ExtractOptions) -> Extraction {
    if let Some(d) = opts.fill {
        let (threshold, candidates) = candidates(map, mean, y_at, opts);
        if !candidates.is_empty() {
            return filled(map, y_at, threshold, &candidates, d, opts.max_texels);
        }
    }
    let set = split_lights(map, mean, y_at, opts);
    Extraction {
        residual: clamp_residual(map, set.threshold),
        threshold: set.threshold,
        lights: set.lights,
    }
}

/// The threshold and the positions above it, brightest first, (Y, layer, i, j); none where
/// the map is black or nothing exceeds it.
fn candidates(
    map: &EnvMap,
    mean: f64,
    y_at: &[f64],
    opts: &ExtractOptions,
) -> (f64, Vec<(f64, u32, u32, u32)>) {
    let mut threshold = opts.ratio * mean;
    let mut candidates: Vec<(f64, u32, u32, u32)> = y_at
        .iter()
        .enumerate()
        .filter(|&(_, &y)| y > threshold)
        .map(|(k, &y)| {
            let (layer, i, j) = position(map, k);
            (y, layer, i, j)
        })
        .collect();
    // Brightest first; ties broken by position so the order never depends on the sort (a
    // total order: the unstable sort gives the stable one's result).
    candidates.sort_unstable_by(|a, b| {
        b.0.total_cmp(&a.0)
            .then((a.1, a.3, a.2).cmp(&(b.1, b.3, b.2)))
    });
    if candidates.len() > opts.max_texels {
        threshold = candidates[opts.max_texels].0;
        candidates.retain(|c| c.0 > threshold);
    }
    if mean.is_nan() || mean <= 0.0 || candidates.is_empty() {
        return (f64::INFINITY, Vec::new());
    }
    (threshold, candidates)
}

/// The clamp rule's light texels of `map` ([`split`] without the residual): each candidate's
/// excess over L·τ/Y.
fn split_lights(map: &EnvMap, mean: f64, y_at: &[f64], opts: &ExtractOptions) -> LightSet {
    let (w, h) = (map.width, map.height);
    let (threshold, candidates) = candidates(map, mean, y_at, opts);
    let mut lights = Vec::with_capacity(candidates.len());
    for &(y, layer, i, j) in &candidates {
        // The stored texel this one reads (itself, or the texel inside an angular rim).
        let (si, sj) = map.mapping.integration_source(w, h, i, j).unwrap_or((i, j));
        let l = map.texel(layer, si, sj);
        let keep = (threshold / y) as f32;
        let r = l.map(|c| c * keep);
        lights.push(LightTexel {
            layer,
            i,
            j,
            dir: map.texel_dir(layer, i, j),
            omega: map.mapping.texel_solid_angle(w, h, i, j),
            radiance: [l[0] - r[0], l[1] - r[1], l[2] - r[2]],
        });
    }
    LightSet { threshold, lights }
}

/// [`split`] with a filled residual ([`ExtractOptions::fill`]): the stored texels under
/// `candidates` (their sources), grown by up to `grow` rings of their 8-neighbours in the same
/// layer (a ring only while the cap `max` has room for all the light texels it adds, the
/// positions reading it), form the light set. Each
/// gets the residual luminance [`fill`] finds for it, at most its own and τ, chroma kept;
/// every texel reading a texel of the set is a light texel holding its excess over that
/// residual. Texels are not joined across cube faces or paraboloid halves.
fn filled(
    map: &EnvMap,
    y_at: &[f64],
    threshold: f64,
    candidates: &[(f64, u32, u32, u32)],
    grow: u32,
    max: usize,
) -> Extraction {
    let (w, h) = (map.width, map.height);
    let own = every_texel_its_own(map);
    let source = |i: u32, j: u32| map.mapping.integration_source(w, h, i, j);
    // Luminance of every stored texel the mapping reads (NaN elsewhere): `y_at` itself
    // where every texel is its own source, else without the rim slivers reading another.
    let y: std::borrow::Cow<[f64]> = if own {
        std::borrow::Cow::Borrowed(y_at)
    } else {
        let mut y = y_at.to_vec();
        for (k, v) in y.iter_mut().enumerate() {
            let (_, i, j) = position(map, k);
            if !v.is_nan() && source(i, j) != Some((i, j)) {
                *v = f64::NAN;
            }
        }
        std::borrow::Cow::Owned(y)
    };
    let mut set = vec![false; map.texels.len()];
    for &(_, layer, i, j) in candidates {
        let (si, sj) = source(i, j).unwrap_or((i, j));
        set[map.index(layer, si, sj)] = true;
    }
    // The cap counts light texels, the positions reading the set: the candidates, and for
    // each texel a ring adds, the positions reading it (more than itself at an angular rim).
    let mut count = candidates.len();
    let readers: Vec<u32> = if own {
        Vec::new()
    } else {
        let mut r = vec![0u32; y_at.len()];
        for k in (0..y_at.len()).filter(|&k| !y_at[k].is_nan()) {
            let (layer, i, j) = position(map, k);
            if let Some((si, sj)) = source(i, j) {
                r[map.index(layer, si, sj)] += 1;
            }
        }
        r
    };
    let reading = |k: usize| readers.get(k).map_or(1, |&r| r as usize);
    let wrap = map.mapping == super::mapping::Mapping::LatLong;
    // A texel's neighbour at (di, dj) in its layer, wrapping in u on a lat-long; positions
    // carry their coordinates, so a step divides nothing (dividing the index back into
    // them took most of the growth's time).
    let step = |p: Pos, di: i64, dj: i64| {
        let (ii, jj) = (p.i as i64 + di, p.j as i64 + dj);
        let ii = if wrap { ii.rem_euclid(w as i64) } else { ii };
        ((0..w as i64).contains(&ii) && (0..h as i64).contains(&jj)).then(|| Pos {
            k: map.index(p.layer, ii as u32, jj as u32),
            layer: p.layer,
            i: ii as u32,
            j: jj as u32,
        })
    };
    let at = |k: usize| {
        let (layer, i, j) = position(map, k);
        Pos { k, layer, i, j }
    };
    // Grown one texel at a time, while the cap leaves room for the whole ring.
    let mut edge: Vec<Pos> = (0..set.len()).filter(|&k| set[k]).map(at).collect();
    let mut members = edge.clone();
    for _ in 0..grow {
        let mut ring = Vec::new();
        for &p in &edge {
            for n in RING.iter().filter_map(|&(di, dj)| step(p, di, dj)) {
                if !set[n.k] && y[n.k] > 0.0 {
                    set[n.k] = true;
                    ring.push(n);
                }
            }
        }
        let added: usize = ring.iter().map(|p| reading(p.k)).sum();
        if count + added > max {
            for p in &ring {
                set[p.k] = false;
            }
            break;
        }
        count += added;
        members.extend_from_slice(&ring);
        edge = ring;
    }
    let f = fill(&y, &set, &step, &members);
    let mut residual = map.clone();
    for &Pos { k, .. } in &members {
        if y[k] > 0.0 {
            // An unreached texel's NaN takes the threshold here.
            let keep = (f[k].min(threshold).min(y[k]) / y[k]) as f32;
            residual.texels[k] = map.texels[k].map(|c| c * keep);
        }
    }
    // The positions reading a member: the members themselves where every texel is its own
    // source, else every position whose source is one (in any order: the list is sorted
    // below).
    let readers: Vec<(usize, usize)> = if own {
        members.iter().map(|p| (p.k, p.k)).collect()
    } else {
        (0..y_at.len())
            .filter(|&k| !y_at[k].is_nan())
            .filter_map(|k| {
                let (layer, i, j) = position(map, k);
                let (si, sj) = source(i, j).unwrap_or((i, j));
                let s = map.index(layer, si, sj);
                set[s].then_some((k, s))
            })
            .collect()
    };
    let mut lights = Vec::new();
    for (at, k) in readers {
        let (layer, i, j) = position(map, at);
        let (l, r) = (map.texels[k], residual.texels[k]);
        let excess = [l[0] - r[0], l[1] - r[1], l[2] - r[2]];
        if excess.iter().all(|&e| e == 0.0) {
            continue;
        }
        lights.push((
            y_at[at],
            LightTexel {
                layer,
                i,
                j,
                dir: map.texel_dir(layer, i, j),
                omega: map.mapping.texel_solid_angle(w, h, i, j),
                radiance: excess,
            },
        ));
    }
    lights.sort_unstable_by(|a, b| {
        b.0.total_cmp(&a.0)
            .then((a.1.layer, a.1.j, a.1.i).cmp(&(b.1.layer, b.1.j, b.1.i)))
    });
    Extraction {
        threshold,
        lights: lights.into_iter().map(|l| l.1).collect(),
        residual,
    }
}

/// A texel's 8 neighbours (rows, then columns, in order).
const RING: [(i64, i64); 8] = [
    (-1, -1),
    (0, -1),
    (1, -1),
    (-1, 0),
    (1, 0),
    (-1, 1),
    (0, 1),
    (1, 1),
];

/// A texel position: its index in the map, layer, column and row.
#[derive(Clone, Copy, Debug)]
struct Pos {
    k: usize,
    layer: u32,
    i: u32,
    j: u32,
}

/// A texel's 4 edge neighbours, in [`RING`]'s order (the diagonal ones sit √2 away).
const EDGE: [(i64, i64); 4] = [(0, -1), (-1, 0), (1, 0), (0, 1)];

/// The residual luminance under a light set: texels outside `set` keep their own (`y`);
/// those in it take, round by round from the set's edge inwards, the mean of their edge
/// neighbours (`step`) that earlier rounds settled, so the residual continues the
/// surroundings under a light instead of stopping at a plateau; `members` lists the set's
/// texels. Texels no round reaches (a layer wholly in the set) stay NaN, which the caller's
/// clamp turns into the threshold (`f64::min` returns the other operand).
fn fill(
    y: &[f64],
    set: &[bool],
    step: &dyn Fn(Pos, i64, i64) -> Option<Pos>,
    members: &[Pos],
) -> Vec<f64> {
    let mut f = y.to_vec();
    for p in members {
        f[p.k] = f64::NAN;
    }
    // A round looks only at the open texels beside the last round's (the first at all of
    // them): a texel no settled neighbour touches cannot settle, and the rounds' values do
    // not depend on the order within a round. Rescanning every open texel each round took
    // most of a 1k studio map's extraction.
    let open = |k: usize| set[k] && !y[k].is_nan();
    let mut round: Vec<Pos> = members
        .iter()
        .copied()
        .filter(|p| !y[p.k].is_nan())
        .collect();
    let mut queued = vec![false; y.len()];
    while !round.is_empty() {
        let mut settled = Vec::new();
        for &p in &round {
            queued[p.k] = false;
            let (mut sum, mut n) = (0.0, 0);
            for m in EDGE.iter().filter_map(|&(di, dj)| step(p, di, dj)) {
                if !f[m.k].is_nan() {
                    sum += f[m.k];
                    n += 1;
                }
            }
            if n > 0 {
                settled.push((p, sum / n as f64));
            }
        }
        for &(p, v) in &settled {
            f[p.k] = v;
        }
        round.clear();
        for &(p, _) in &settled {
            for m in EDGE.iter().filter_map(|&(di, dj)| step(p, di, dj)) {
                if open(m.k) && f[m.k].is_nan() && !queued[m.k] {
                    queued[m.k] = true;
                    round.push(m);
                }
            }
        }
    }
    f
}

/// The quadrature nodes of light texel `t` of `map`: `cells` × `cells` cells of 2 × 2
/// Gauss–Legendre points, directions (file frame) with weights (the mapping's density)
/// scaled to the texel's exact solid angle, what a sum takes where a lobe bends across it.
pub fn nodes(map: &EnvMap, t: &LightTexel, cells: u32) -> Vec<(DVec3, f64)> {
    let g = 0.5 / 3f64.sqrt();
    let side = 2 * cells;
    let at =
        |n: u32| ((n / 2) as f64 + 0.5 + if n.is_multiple_of(2) { -g } else { g }) / cells as f64;
    let mut v = Vec::with_capacity((side * side) as usize);
    for b in 0..side {
        for a in 0..side {
            let c = Coord {
                layer: t.layer,
                u: (t.i as f64 + at(a)) / map.width as f64,
                v: (t.j as f64 + at(b)) / map.height as f64,
            };
            v.push((map.mapping.coord_to_dir(c), map.mapping.footprint_weight(c)));
        }
    }
    let total: f64 = v.iter().map(|n| n.1).sum();
    if total > 0.0 {
        for n in &mut v {
            n.1 *= t.omega / total;
        }
    } else {
        let n = v.len() as f64;
        for (d, w) in &mut v {
            *d = t.dir;
            *w = t.omega / n;
        }
    }
    v
}

/// Whether light texels' quadratures resolve lobes down to `scale` (at most 8 cells a side
/// needed, [`cells_for`]'s cap): a narrower lobe (a Phong n of 10⁶, GGX near the mirror)
/// would fall between the nodes, so techniques read the whole map instead.
pub fn resolves(ex: &Extraction, scale: f64) -> bool {
    resolves_rho(largest_light_rho(&ex.lights), scale)
}

/// ρ = √Ω of the largest of `lights` (0 for none).
pub fn largest_light_rho(lights: &[LightTexel]) -> f64 {
    lights.iter().map(|t| t.omega.sqrt()).fold(0.0, f64::max)
}

/// [`resolves`] for texels up to ρ = `rho`.
pub fn resolves_rho(rho: f64, scale: f64) -> bool {
    PER_WIDTH * rho <= 8.0 * scale
}

/// ρ = √Ω of the largest texel of a `width` × `height` layer of `mapping`: the equator's
/// for lat-long, the centre's for the others (their densities peak there), so the two middle
/// rows hold it.
pub fn largest_rho(mapping: super::Mapping, width: u32, height: u32) -> f64 {
    let rows = [height / 2, (height / 2).saturating_sub(1)];
    rows.iter()
        .flat_map(|&j| (0..width).map(move |i| (i, j)))
        .map(|(i, j)| mapping.texel_solid_angle(width, height, i, j))
        .fold(0.0, f64::max)
        .sqrt()
}

/// Cells per side of every light texel's quadrature for lobes down to `alpha`:
/// ⌈[`PER_WIDTH`]·ρ/α⌉ for the largest texel, 1 to 8 (the exact oracle's rule,
/// [`super::exact::ExactFilter::ggx`], at the lobe's peak).
pub fn cells_for(ex: &Extraction, alpha: f64) -> u32 {
    cells_for_rho(largest_light_rho(&ex.lights), alpha)
}

/// [`cells_for`] for texels up to ρ = `rho`.
pub fn cells_for_rho(rho: f64, alpha: f64) -> u32 {
    let a = alpha.max(super::brdf::GGX_ALPHA_MIN);
    ((PER_WIDTH * rho / a).ceil() as u32).clamp(1, 8)
}

pub use crate::abi::lights::{CENTRE_BELOW, PER_WIDTH, TAIL_FRACTION};

/// A kernel's scale at a light texel `chord` from the lobe's axis: the lobe's own `scale`,
/// or [`TAIL_FRACTION`] of the chord in the tail.
pub fn scale_at(scale: f64, chord: f64) -> f64 {
    scale.max(TAIL_FRACTION * chord)
}

/// Whether light texel `t` takes its centre alone where the kernel's scale is `width`
/// ([`PER_WIDTH`]·ρ < [`CENTRE_BELOW`]·w), or has no nodes.
fn centre_only(t: &PreparedLight, width: f64) -> bool {
    t.nodes.is_empty() || PER_WIDTH * t.rho < CENTRE_BELOW * width
}

/// A kernel the light texels are summed with.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum LightKernel {
    /// max(0, r·ω): irradiance.
    Cosine,
    /// `super::split_sum::chain_kernel` at α.
    Ggx {
        /// GGX α.
        alpha: f64,
    },
}

/// One light texel ready for sums: world centre, solid angle, excess radiance, angular size
/// and quadrature nodes (world).
#[derive(Clone, Debug, PartialEq)]
pub struct PreparedLight {
    /// Centre direction (world).
    pub dir: DVec3,
    /// Solid angle.
    pub omega: f64,
    /// Excess radiance.
    pub radiance: [f64; 3],
    /// √Ω.
    pub rho: f64,
    /// `nodes`, turned to the world.
    pub nodes: Vec<(DVec3, f64)>,
    /// The quadratures of fewer cells, 1 to those of `nodes` less one ((2c)² nodes each,
    /// coarsest first, set c from `coarse_offset``(c)`), turned to the world: where they
    /// are kept (`prepare_local`) a texel's integral takes only as many cells as the
    /// kernel's scale at it asks (`local_nodes`); empty: always `nodes`.
    pub coarse: Vec<(DVec3, f64)>,
}

/// Where the quadrature of `cells` cells starts in [`PreparedLight::coarse`]: Σ (2c)² over
/// c = 1 … cells − 1.
pub fn coarse_offset(cells: u32) -> usize {
    let c = cells.max(1) as usize;
    2 * (c - 1) * c * (2 * c - 1) / 3
}

/// [`prepare_cells`] with every coarser quadrature kept ([`PreparedLight::coarse`]), for the
/// local rule (`local_nodes`; a bake's `glsl/lights.comp`): in GGX's tail, where the
/// kernel is wider than at its peak, a texel takes 4 nodes instead of (2·cells)², by the same
/// rule per node ([`light_sum_local`]'s).
pub fn prepare_local(
    map: &EnvMap,
    lights: &[LightTexel],
    file_to_world: glam::DMat3,
    cells: u32,
) -> Vec<PreparedLight> {
    let mut prepared = prepare_cells(map, lights, file_to_world, cells);
    for (p, t) in prepared.iter_mut().zip(lights) {
        p.coarse = (1..cells)
            .flat_map(|c| nodes(map, t, c))
            .map(|(d, w)| (file_to_world * d, w))
            .collect();
    }
    prepared
}

/// Cells per side of a quadrature of `nodes` = (2·cells)² nodes (1 for none).
pub fn cells_of_nodes(nodes: u32) -> u32 {
    ((nodes as f64).sqrt().round() as u32 / 2).max(1)
}

/// The nodes light texel `t`'s integral takes where the kernel's scale at it is `width`:
/// with coarser quadratures kept, those of ⌈[`PER_WIDTH`]·ρ/w⌉ cells (1 to 8) where that is
/// fewer than `t.nodes` has, else `t.nodes`.
pub fn local_nodes(t: &PreparedLight, width: f64) -> &[(DVec3, f64)] {
    if t.coarse.is_empty() {
        return &t.nodes;
    }
    let fine = cells_of_nodes(t.nodes.len() as u32);
    let c = ((PER_WIDTH * t.rho / width).ceil() as u32).clamp(1, 8);
    match c < fine {
        true => &t.coarse[coarse_offset(c)..coarse_offset(c + 1)],
        false => &t.nodes,
    }
}

/// The light texels of `ex` (of `map`, whose file directions reach the world through
/// `file_to_world`) ready for [`light_sum`] and the GPU, with quadratures fine enough for
/// lobes down to GGX `alpha` ([`cells_for`]).
pub fn prepare(
    map: &EnvMap,
    ex: &Extraction,
    file_to_world: glam::DMat3,
    alpha: f64,
) -> Vec<PreparedLight> {
    prepare_cells(map, &ex.lights, file_to_world, cells_for(ex, alpha))
}

/// [`prepare`] with `cells` per side of every texel's quadrature: the twin of the GPU's
/// preparation (`glsl/extract_prepare.comp`), whose cells come from the map's largest texel
/// ([`cells_for_rho`] of [`largest_rho`]) since it cannot wait for what a frame extracts.
pub fn prepare_cells(
    map: &EnvMap,
    lights: &[LightTexel],
    file_to_world: glam::DMat3,
    cells: u32,
) -> Vec<PreparedLight> {
    lights
        .iter()
        .map(|t| PreparedLight {
            dir: file_to_world * t.dir,
            omega: t.omega,
            radiance: t.radiance.map(f64::from),
            rho: t.omega.sqrt(),
            nodes: nodes(map, t, cells)
                .into_iter()
                .map(|(d, w)| (file_to_world * d, w))
                .collect(),
            coarse: Vec::new(),
        })
        .collect()
}

/// Σ_t L_t·∫_t K(r·ω) dω over the light texels (not normalised), each integral by one node
/// at the texel's centre where [`PER_WIDTH`]·ρ < [`CENTRE_BELOW`]·w, w the kernel's scale
/// there (α at GGX's peak, [`TAIL_FRACTION`] of the chord in its θ⁻⁴ tail, a radian for the
/// cosine), else by its nodes. The float64 twin of `glsl/lights.comp`.
pub fn light_sum(lights: &[PreparedLight], r: DVec3, kernel: LightKernel) -> [f64; 3] {
    let (scale, kern) = kernel_of(kernel, r);
    let mut sum = [0.0; 3];
    for t in lights {
        let k = texel_integral(t, scale, r, &kern);
        for (s, l) in sum.iter_mut().zip(t.radiance) {
            *s += k * l;
        }
    }
    sum
}

/// [`light_sum`] of `ex`'s texels with each texel's nodes only as fine as the kernel's scale
/// w at that texel asks: (2·cells)² nodes, cells = ⌈[`PER_WIDTH`]·ρ/w⌉ (1 to 8), where
/// [`prepare`] takes one count for every texel from the largest ρ and the lobe's own scale.
/// The rule per node is the same ([`PER_WIDTH`] nodes across the local width), and far in
/// the tail, where w ≫ α, a texel takes 4 nodes instead of up to 256. The float64 twin of
/// `Extractor::record_add` (glsl/extract_add.comp).
pub fn light_sum_local(
    map: &EnvMap,
    ex: &Extraction,
    file_to_world: glam::DMat3,
    r: DVec3,
    kernel: LightKernel,
) -> [f64; 3] {
    let (scale, kern) = kernel_of(kernel, r);
    let mut sum = [0.0; 3];
    for t in &ex.lights {
        let centre = file_to_world * t.dir;
        let rho = t.omega.sqrt();
        let w = scale_at(scale, (r - centre).length());
        let k = if PER_WIDTH * rho < CENTRE_BELOW * w {
            kern(centre) * t.omega
        } else {
            let cells = ((PER_WIDTH * rho / w).ceil() as u32).clamp(1, 8);
            nodes(map, t, cells)
                .into_iter()
                .map(|(d, wt)| kern(file_to_world * d) * wt)
                .sum()
        };
        for (s, l) in sum.iter_mut().zip(t.radiance) {
            *s += k * l as f64;
        }
    }
    sum
}

/// A kernel's scale and its value along a direction, about `r`.
pub(crate) fn kernel_of(kernel: LightKernel, r: DVec3) -> (f64, impl Fn(DVec3) -> f64) {
    let scale = match kernel {
        LightKernel::Cosine => 1.0,
        LightKernel::Ggx { alpha } => alpha.max(super::brdf::GGX_ALPHA_MIN),
    };
    (scale, move |w: DVec3| {
        let g = 0.5 * (r - w).length_squared();
        match kernel {
            LightKernel::Cosine => (1.0 - g).max(0.0),
            LightKernel::Ggx { alpha } => super::split_sum::chain_kernel(alpha, g),
        }
    })
}

/// ∫_t K dω over light texel `t` (radiance not applied) for a kernel `kern` of scale `scale`
/// about `r`: by its centre where [`PER_WIDTH`]·ρ < [`CENTRE_BELOW`]·w (w the scale, or
/// [`TAIL_FRACTION`] of the chord to `r` in the tail), else by its nodes (`local_nodes`).
pub fn texel_integral(t: &PreparedLight, scale: f64, r: DVec3, kern: impl Fn(DVec3) -> f64) -> f64 {
    let width = scale_at(scale, (r - t.dir).length());
    if centre_only(t, width) {
        kern(t.dir) * t.omega
    } else {
        local_nodes(t, width)
            .iter()
            .map(|&(d, w)| kern(d) * w)
            .sum()
    }
}

/// The angular scale of `brdf`'s lobe about the reflected direction, what [`light_sum_brdf`]
/// compares a light texel's size with: α for GGX, 1/√n for Phong, 2/√n for Blinn (a
/// half-vector lobe), the narrower α for Ward, a radian for Lambert; `None` for the mirror,
/// whose lobe no texel quadrature resolves (it reads the whole map instead).
pub fn lobe_scale(brdf: &Brdf) -> Option<f64> {
    match *brdf {
        Brdf::Mirror => None,
        Brdf::Lambert => Some(1.0),
        Brdf::Ggx { alpha, .. } => Some(alpha.max(super::brdf::GGX_ALPHA_MIN)),
        Brdf::Phong { n } => Some(1.0 / n.max(1.0).sqrt()),
        Brdf::Blinn { n } => Some(2.0 / n.max(1.0).sqrt()),
        Brdf::Ward { ax, ay } => Some(ax.min(ay).max(super::brdf::WARD_ALPHA_MIN)),
    }
}

/// Σ_t L_t·∫_t f(v, ω)·cos θ dω over the light texels at a surface of normal `n` seen along
/// `v` (unit, towards the eye): each texel by its centre where [`PER_WIDTH`]·ρ <
/// [`CENTRE_BELOW`]·w, w the lobe's `scale` ([`lobe_scale`]) or, in the tail,
/// [`TAIL_FRACTION`] of the chord to the reflected direction, else by its nodes. In the frame and with the view lift of
/// [`super::fis::estimate`]; the float64 twin of `shade.frag`'s lights for FIS materials.
pub fn light_sum_brdf(
    lights: &[PreparedLight],
    brdf: &Brdf,
    n: DVec3,
    v: DVec3,
    scale: f64,
) -> [f64; 3] {
    let frame = Frame::new(n);
    let wo = local_view(&frame, v);
    let r = 2.0 * n.dot(v) * n - v;
    let eval = |d: DVec3| brdf.eval_cos(wo, frame.to_local(d));
    let mut sum = [0.0; 3];
    for t in lights {
        let k = texel_integral(t, scale, r, eval);
        for (s, l) in sum.iter_mut().zip(t.radiance) {
            *s += k * l;
        }
    }
    sum
}

/// The GPU's list: per light texel (centre, Ω), (excess, ρ), then its nodes (direction,
/// weight), `crate::abi::lights::HEADER_VEC4S` + `nodes` vec4s each.
pub fn gpu_list(lights: &[PreparedLight]) -> Vec<[f32; 4]> {
    let mut v = Vec::new();
    for t in lights {
        v.push([
            t.dir.x as f32,
            t.dir.y as f32,
            t.dir.z as f32,
            t.omega as f32,
        ]);
        let l = t.radiance;
        v.push([l[0] as f32, l[1] as f32, l[2] as f32, t.rho as f32]);
        for &(d, w) in &t.nodes {
            v.push([d.x as f32, d.y as f32, d.z as f32, w as f32]);
        }
    }
    v
}

/// Where a map's file direction lands among its texels (for tests and reports).
pub fn texel_of(map: &EnvMap, d: DVec3) -> (u32, u32, u32) {
    let c = map.coord(d);
    let at = |x: f64, n: u32| ((x * n as f64).floor().max(0.0) as u32).min(n - 1);
    (c.layer, at(c.u, map.width), at(c.v, map.height))
}

#[cfg(test)]
mod tests;
