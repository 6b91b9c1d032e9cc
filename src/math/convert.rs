//! The float64 twin of the conversion pass (`glsl/convert.comp`): the same reconstruction
//! (masked bilinear, lat-long rows between their solid-angle centroids, seamless cube
//! filtering) and the same footprint means, as the oracle the GPU is tested against.

use super::mapping::{Coord, Mapping};
use crate::abi::area;
use crate::math::envmap::EnvMap;
use glam::{DMat3, DVec3};
use std::f64::consts::PI;

mod plan;
pub use plan::{apply_area_plan, area_plan, AreaPlan, PlanEntry};

/// Polar angle of the solid-angle centroid of lat-long row `j` of height `h` (rows −1 and H are
/// rows 0 and H−1 seen across the pole).
pub fn row_centroid(j: i64, h: f64) -> f64 {
    let tm = (j as f64 + 0.5) * h;
    let x = 0.5 * h;
    // cot θm · (1 − x cot x)
    tm + tm.cos() / tm.sin() * (1.0 - x / x.tan())
}

fn fetch(map: &EnvMap, layer: u32, i: i64, j: i64) -> [f64; 3] {
    map.texel(layer, i as u32, j as u32).map(f64::from)
}

/// Radiance of a map towards `d`, reconstructed as the GPU does.
pub fn sample(map: &EnvMap, d: DVec3) -> [f64; 3] {
    let (w, h) = (map.width as i64, map.height as i64);
    let c = map.mapping.dir_to_coord(d);
    let px = c.u * w as f64 - 0.5;
    let py = c.v * h as f64 - 0.5;
    let (i0, mut j0) = (px.floor() as i64, py.floor() as i64);
    let tx = px - i0 as f64;
    let mut ty = py - j0 as f64;
    if map.mapping == Mapping::LatLong {
        let hh = PI / h as f64;
        let theta = PI * c.v;
        let (mut c0, mut c1) = (row_centroid(j0, hh), row_centroid(j0 + 1, hh));
        if theta < c0 {
            j0 -= 1;
            c1 = c0;
            c0 = row_centroid(j0, hh);
        } else if theta >= c1 {
            j0 += 1;
            c0 = c1;
            c1 = row_centroid(j0 + 1, hh);
        }
        ty = ((theta - c0) / (c1 - c0)).clamp(0.0, 1.0);
    }
    let mut acc = [0.0; 3];
    let mut wsum = 0.0;
    let mut nearest = [0.0; 3];
    for k in 0..4 {
        let (mut qi, mut qj) = (i0 + (k & 1), j0 + (k >> 1));
        let wt =
            (if k & 1 == 1 { tx } else { 1.0 - tx }) * (if k >> 1 == 1 { ty } else { 1.0 - ty });
        let mut layer = c.layer;
        match map.mapping {
            Mapping::LatLong => {
                if qj < 0 {
                    (qi, qj) = (qi + w / 2, -1 - qj);
                } else if qj >= h {
                    (qi, qj) = (qi + w / 2, 2 * h - 1 - qj);
                }
                qi = qi.rem_euclid(w);
            }
            Mapping::Cube if qi < 0 || qi >= w || qj < 0 || qj >= h => {
                // Seamless filtering: the texel past the edge is the adjacent face's texel in
                // that direction.
                let virt = Coord {
                    layer,
                    u: (qi as f64 + 0.5) / w as f64,
                    v: (qj as f64 + 0.5) / h as f64,
                };
                let e = Mapping::Cube.dir_to_coord(Mapping::Cube.coord_to_dir(virt));
                layer = e.layer;
                qi = ((e.u * w as f64).floor() as i64).clamp(0, w - 1);
                qj = ((e.v * h as f64).floor() as i64).clamp(0, h - 1);
            }
            _ => {}
        }
        qi = qi.clamp(0, w - 1);
        qj = qj.clamp(0, h - 1);
        let v = fetch(map, layer, qi, qj);
        if k == 0 || wt > 0.25 {
            nearest = v;
        }
        if !map
            .mapping
            .texel_in_domain(map.width, map.height, qi as u32, qj as u32)
        {
            continue;
        }
        for ch in 0..3 {
            acc[ch] += wt * v[ch];
        }
        wsum += wt;
    }
    if wsum > 0.0 {
        acc.map(|x| x / wsum)
    } else {
        nearest
    }
}

/// The texel of `map` that `d` falls in (the conversion's `nearest` reconstruction).
pub fn sample_nearest(map: &EnvMap, d: DVec3) -> [f64; 3] {
    let c = map.mapping.dir_to_coord(d);
    let i = ((c.u * map.width as f64).floor() as i64).clamp(0, map.width as i64 - 1);
    let j = ((c.v * map.height as f64).floor() as i64).clamp(0, map.height as i64 - 1);
    fetch(map, c.layer, i, j)
}

/// Converts `map` to `to` at `size` with `ss × ss` samples per output texel, `world_to_file`
/// orienting the source (see [`super::Orientation::world_to_file`]).
pub fn convert(map: &EnvMap, to: Mapping, size: u32, world_to_file: DMat3, ss: u32) -> EnvMap {
    convert_with(map, to, size, world_to_file, ss, false)
}

/// [`convert`], each sample reading the source's nearest texel where `nearest` is set.
pub fn convert_with(
    map: &EnvMap,
    to: Mapping,
    size: u32,
    world_to_file: DMat3,
    ss: u32,
    nearest: bool,
) -> EnvMap {
    let read = |d: DVec3| {
        if nearest {
            sample_nearest(map, d)
        } else {
            sample(map, d)
        }
    };
    let (w, h) = to.extent_for_size(size);
    let mut texels = Vec::with_capacity((w * h * to.layers()) as usize);
    for layer in 0..to.layers() {
        for j in 0..h {
            for i in 0..w {
                if to == Mapping::Angular && !to.texel_in_domain(w, h, i, j) {
                    texels.push([0.0; 3]);
                    continue;
                }
                let (mut acc, mut wsum) = ([0.0f64; 3], 0.0);
                for b in 0..ss {
                    for a in 0..ss {
                        let c = Coord {
                            layer,
                            u: (i as f64 + (a as f64 + 0.5) / ss as f64) / w as f64,
                            v: (j as f64 + (b as f64 + 0.5) / ss as f64) / h as f64,
                        };
                        let wt = to.footprint_weight(c);
                        let l = read(world_to_file * to.coord_to_dir(c));
                        for k in 0..3 {
                            acc[k] += wt * l[k];
                        }
                        wsum += wt;
                    }
                }
                if wsum > 0.0 {
                    texels.push(acc.map(|x| (x / wsum) as f32));
                } else {
                    // A paraboloid texel whose samples all miss its disc holds its own half's
                    // rim nearest its centre (as glsl/convert.comp).
                    let c = if to == Mapping::DualParaboloid {
                        rim_nearest(w, h, layer, i, j)
                    } else {
                        Mapping::texel_center(w, h, layer, i, j)
                    };
                    texels.push(read(world_to_file * to.coord_to_dir(c)).map(|x| x as f32));
                }
            }
        }
    }
    EnvMap::new(to, w, h, texels)
}

/// Whether [`latlong_area`] serves a `width` × `height` lat-long → `to` at `size` conversion: a
/// cube, or a dual paraboloid whose axis is the lat-long's polar axis (`world_to_file` keeps
/// +Y), so that its rim is the equator, the line z = 0 of the (U, z) plane; and polygon walks
/// that stay within `area::WALK_STEPS` ([`area_walk_steps`]).
pub fn area_serves(width: u32, height: u32, to: Mapping, size: u32, world_to_file: DMat3) -> bool {
    let mapped = match to {
        Mapping::Cube => true,
        Mapping::DualParaboloid => world_to_file.y_axis == DVec3::Y,
        _ => false,
    };
    mapped && area_walk_steps(width, height, to, size) <= area::WALK_STEPS
}

/// `map`, a lat-long of even width and height, at half its width and height: each texel the
/// solid-angle mean of the four it covers (summed in float64), so that the power is the
/// map's to float32 rounding. Panics on any other map (a caller bug; see
/// [`paraboloid_source_halves`]).
pub fn latlong_halved(map: &EnvMap) -> EnvMap {
    assert!(
        map.mapping == Mapping::LatLong
            && map.width.is_multiple_of(2)
            && map.height.is_multiple_of(2),
        "only a lat-long of even sides halves exactly"
    );
    let (w, h) = (map.width / 2, map.height / 2);
    let mut texels = Vec::with_capacity(w as usize * h as usize);
    for j in 0..h {
        // A row's texels share one solid angle; the coarse texel's is twice the two rows'.
        let o = [2 * j, 2 * j + 1]
            .map(|r| Mapping::LatLong.texel_solid_angle(map.width, map.height, 0, r));
        let sum = 2.0 * (o[0] + o[1]);
        let (a, b) = (o[0] / sum, o[1] / sum);
        for i in 0..w {
            let t = |di: u32, dj: u32| map.texel(0, 2 * i + di, 2 * j + dj).map(f64::from);
            let (p, q, r, s) = (t(0, 0), t(1, 0), t(0, 1), t(1, 1));
            texels.push([0, 1, 2].map(|c| (a * (p[c] + q[c]) + b * (r[c] + s[c])) as f32));
        }
    }
    EnvMap::new(Mapping::LatLong, w, h, texels)
}

/// Whether a `width` × `height` lat-long is halved ([`latlong_halved`]) before its area
/// conversion to a dual paraboloid of side `size`: where its sides are even and the halved
/// map's texels are no larger than the paraboloid's finest (2/size radians across, at its
/// rim; 2π/W' along the equator, π/H' down a column). The conversion integrates the source
/// over each output texel at any resolution, so power is kept; halving only moves each
/// texel's power within its 2 × 2 block, no wider than the paraboloid's finest texel. Once
/// only: halving twice moves power across blocks wider than a texel (tests/shade.rs measures
/// the error on a checker of 2 × 2-texel cells).
pub fn paraboloid_source_halves(width: u32, height: u32, size: u32) -> bool {
    let finest = 2.0 / f64::from(size.max(1));
    width.is_multiple_of(2)
        && height.is_multiple_of(2)
        && 2.0 * PI / f64::from(width / 2) <= finest
        && PI / f64::from(height / 2) <= finest
}

/// Loop steps of the longest polygon walk of a `width` × `height` lat-long → `to` at `size`
/// conversion (llvmpipe ends an invocation's loops after 65 535 steps in all): the texel with
/// a corner on a pole, which meets the rows down to its far corner (2√2/size of a face's
/// side, 2× that on a paraboloid, whose texels are twice as wide there), and in each clips
/// its polygon twice (2 · `area::MAX_VERTICES` steps) and walks a quarter of the row's
/// columns along each of its two edges that leave the pole.
pub fn area_walk_steps(width: u32, height: u32, to: Mapping, size: u32) -> f64 {
    let reach = match to {
        Mapping::DualParaboloid => 4.0 * std::f64::consts::SQRT_2,
        _ => 2.0 * std::f64::consts::SQRT_2,
    } / size.max(1) as f64;
    let rows = (reach / PI * height as f64).ceil() + 1.0;
    rows * (2.0 * area::MAX_VERTICES as f64 + 0.5 * width as f64)
}

/// Whether the area conversion to a cube or dual paraboloid of side `n` leaves texel
/// (`i`, `j`) of `layer` to the general walk rather than its fast path
/// (glsl/convert_area.glsl, twin of `general_texel`): every texel below
/// `area::FAST_MIN_SIZE`; the window of `area::FAST_WINDOW` texels about the centre of
/// the layers that hold the poles (the cube's +Y and −Y faces, each paraboloid half), where
/// the polygons meet the pole's axis or come near it; and a paraboloid's texels that the rim
/// of its disc cuts or that lie outside it (a corner outside the disc), whose polygons are
/// clipped to their half. Integer tests, so that the two dispatches split the texels exactly.
pub fn area_general_texel(to: Mapping, layer: u32, i: u32, j: u32, n: u32) -> bool {
    if n < area::FAST_MIN_SIZE {
        return true;
    }
    let lim = 2 * area::FAST_WINDOW as i64;
    let window =
        (2 * i as i64 + 1 - n as i64).abs() <= lim && (2 * j as i64 + 1 - n as i64).abs() <= lim;
    match to {
        Mapping::DualParaboloid => {
            let n2 = n as i64 * n as i64;
            let out = |c: u32, d: u32| {
                let (a, b) = (2 * c as i64 - n as i64, 2 * d as i64 - n as i64);
                a * a + b * b > n2
            };
            out(i, j) || out(i + 1, j) || out(i, j + 1) || out(i + 1, j + 1) || window
        }
        _ => area::POLE_FACES.contains(&layer) && window,
    }
}

/// The texels of a cube or dual paraboloid of side `n` that [`area_general_texel`] leaves to
/// the general walk, as (i, j, layer, 0), layer by layer and row by row: on a paraboloid, only
/// those that overlap its disc. Those wholly outside it take the nearest rim texel's copy
/// in the fast path's dispatch, whose module lacks the clip's arrays that make every lane
/// of the general walk's dear.
pub fn area_general_texels(to: Mapping, n: u32) -> Vec<[u32; 4]> {
    let mut list = Vec::new();
    for layer in 0..to.layers() {
        // A cube's pole faces' windows (a paraboloid's rims and windows), unless the map is
        // small enough to be all general.
        let (lo, hi) = if n < area::FAST_MIN_SIZE || to == Mapping::DualParaboloid {
            (0, n)
        } else if area::POLE_FACES.contains(&layer) {
            let half = area::FAST_WINDOW + 1;
            ((n / 2).saturating_sub(half), (n / 2 + half).min(n))
        } else {
            continue;
        };
        for j in lo..hi {
            for i in lo..hi {
                if area_general_texel(to, layer, i, j, n) && to.texel_in_domain(n, n, i, j) {
                    list.push([i, j, layer, 0]);
                }
            }
        }
    }
    list
}

/// The workgroup tiles (`WORKGROUP_2D` texels, (tile column, tile row, layer, 0)) the split
/// area conversion to a cube or dual paraboloid of side `n` dispatches over: first those
/// holding a texel its fast path computes, then a paraboloid's holding a texel outside its
/// disc (none for a cube). The fast path's cost is per tile whatever its texels do (llvmpipe
/// runs a returned lane's straight-line code), so tiles with no fast texel, a fifth of a
/// paraboloid's at 512², are left out; the texels outside the disc take their rim's source
/// texel in a dispatch of their own.
pub fn area_tiles(to: Mapping, n: u32) -> (Vec<[u32; 4]>, Vec<[u32; 4]>) {
    let [tw, th] = crate::abi::WORKGROUP_2D;
    let (mut fast, mut rim) = (Vec::new(), Vec::new());
    for layer in 0..to.layers() {
        for ty in 0..n.div_ceil(th) {
            for tx in 0..n.div_ceil(tw) {
                let texels = (ty * th..((ty + 1) * th).min(n))
                    .flat_map(|j| (tx * tw..((tx + 1) * tw).min(n)).map(move |i| (i, j)));
                let (mut has_fast, mut has_rim) = (false, false);
                for (i, j) in texels {
                    has_fast |= !area_general_texel(to, layer, i, j, n);
                    has_rim |= !to.texel_in_domain(n, n, i, j);
                }
                if has_fast {
                    fast.push([tx, ty, layer, 0]);
                }
                if has_rim {
                    rim.push([tx, ty, layer, 0]);
                }
            }
        }
    }
    (fast, rim)
}

/// A lat-long → cube or dual-paraboloid conversion that conserves power: each output texel
/// holds the mean of the source over its footprint, the source reconstructed per texel as its
/// value plus its limited slopes ([`area_slopes`]). Lat-long texels are rectangles in the
/// equal-area plane (U, z) = (φ·W/2π, cos θ), where dω = (2π/W)·dU·dz; each output texel's
/// footprint is the polygon of points along its edges there (with the pole's line where a
/// point sits on a pole or the texel holds one; a paraboloid texel's clipped to its half, z ≥ 0
/// or z ≤ 0), and its overlap with each source texel is integrated exactly, row band by row
/// band, along the clipped polygon's edges (Green's theorem); a paraboloid's chords add their
/// slivers ([`sliver`], each to the source texel under its curve's midpoint,
/// [`area::PARABOLOID_EDGE_STEPS`]; on edges the rim cuts, their parts inside the half,
/// [`sliver_kept`]). Neighbouring texels share their
/// points bit for bit, so the polygons tile the plane: every source texel's power lands in
/// the output, once. Shared edges are split at band and column lines from a canonical
/// endpoint order, so both sides compute the same pieces (glsl/convert_area.comp is the
/// float32 twin, step for step, U counted from a column near each footprint, except on the
/// cube's fast path, which takes the same integrals edge by edge clamped to each band; see
/// [`area_general_texel`]). Paraboloid texels wholly outside their disc hold the source
/// texel at their own half's rim nearest their centre, as the sampled conversion's do.
/// Panics unless [`area_serves`] maps `to` with `world_to_file`.
pub fn latlong_area(map: &EnvMap, to: Mapping, size: u32, world_to_file: DMat3) -> EnvMap {
    latlong_area_points(map, to, size, world_to_file, area::PARABOLOID_EDGE_STEPS)
}

/// [`latlong_area`] with `edge_points` points per edge of a paraboloid texel's polygon away
/// from the poles (1 to `area::POLE_STEPS`; the converter's `ConvertOptions::edge_points`).
pub fn latlong_area_points(
    map: &EnvMap,
    to: Mapping,
    size: u32,
    world_to_file: DMat3,
    edge_points: u32,
) -> EnvMap {
    assert!((1..=area::POLE_STEPS).contains(&edge_points));
    assert_eq!(map.mapping, Mapping::LatLong);
    assert!(
        area_serves(1, 1, to, size.max(1), world_to_file),
        "no area conversion to {to:?} with this orientation"
    );
    let (w, h) = (map.width as i64, map.height as i64);
    let slopes = area_slopes(map);
    let cell = |row: i64, col: i64| Cell {
        l: fetch(map, 0, col, row),
        slopes: slopes[(row * w + col) as usize],
    };
    let (ow, oh) = to.extent_for_size(size);
    let mut texels = Vec::with_capacity((ow * oh * to.layers()) as usize);
    for layer in 0..to.layers() {
        for j in 0..oh {
            for i in 0..ow {
                if !to.texel_in_domain(ow, oh, i, j) {
                    let c = rim_nearest(ow, oh, layer, i, j);
                    let d = world_to_file * to.coord_to_dir(c);
                    texels.push(sample_nearest(map, d).map(|x| x as f32));
                    continue;
                }
                let mut f = area_polygon(to, layer, i, j, size, w, world_to_file, edge_points);
                if to == Mapping::DualParaboloid {
                    f.poly = cut(&f.poly, 0.0, layer == 0);
                }
                if f.poly.len() < 3 {
                    // Inside the disc by less than the chords' error.
                    let c = rim_nearest(ow, oh, layer, i, j);
                    let d = world_to_file * to.coord_to_dir(c);
                    texels.push(sample_nearest(map, d).map(|x| x as f32));
                    continue;
                }
                texels.push(area_mean(&f, w, h, cell));
            }
        }
    }
    EnvMap::new(to, ow, oh, texels)
}

/// The coordinate on its own half's rim nearest the centre of paraboloid texel (i, j), pulled
/// in by `RIM_PULL_IN` (glsl/include/mappings.glsl's rim_pulled), or the centre where it is
/// inside the disc.
fn rim_nearest(w: u32, h: u32, layer: u32, i: u32, j: u32) -> Coord {
    let mut c = Mapping::texel_center(w, h, layer, i, j);
    let (s, t) = (2.0 * c.u - 1.0, 2.0 * c.v - 1.0);
    let r = 1.0 - crate::abi::constants::RIM_PULL_IN;
    let k = r / (s * s + t * t).sqrt().max(r);
    c.u = 0.5 * (s * k + 1.0);
    c.v = 0.5 * (t * k + 1.0);
    c
}

/// A source texel as the area conversion reconstructs it: its value at its centroid and its
/// limited slopes ∂L/∂U, ∂L/∂z per channel.
#[derive(Clone, Copy)]
struct Cell {
    l: [f64; 3],
    slopes: [[f64; 3]; 2],
}

/// Per texel of a lat-long map, the slopes of its linear reconstruction in (U, z) (central
/// differences, one-sided in the polar rows), limited (Barth–Jespersen) so that across the
/// texel it stays between the least and greatest of the texel and its four neighbours: no new
/// extremum, never negative, and a sun or any lone bright texel stays flat. The linear part
/// integrates to zero over the texel, so power is unchanged (glsl/convert_slopes.comp).
pub fn area_slopes(map: &EnvMap) -> Vec<[[f64; 3]; 2]> {
    let (w, h) = (map.width as i64, map.height as i64);
    let zc = |r: i64| 0.5 * (band_edge(r, h) + band_edge(r + 1, h));
    let mut out = Vec::with_capacity((w * h) as usize);
    for r in 0..h {
        for c in 0..w {
            let l = fetch(map, 0, c, r);
            let left = fetch(map, 0, (c - 1).rem_euclid(w), r);
            let right = fetch(map, 0, (c + 1).rem_euclid(w), r);
            let up = (r > 0).then(|| fetch(map, 0, c, r - 1));
            let down = (r + 1 < h).then(|| fetch(map, 0, c, r + 1));
            let half_dz = 0.5 * (band_edge(r, h) - band_edge(r + 1, h));
            let mut g = [[0.0; 3]; 2];
            for k in 0..3 {
                let gu = 0.5 * (right[k] - left[k]);
                let gz = match (up, down) {
                    (Some(a), Some(b)) => (a[k] - b[k]) / (zc(r - 1) - zc(r + 1)),
                    (None, Some(b)) => (l[k] - b[k]) / (zc(r) - zc(r + 1)),
                    (Some(a), None) => (a[k] - l[k]) / (zc(r - 1) - zc(r)),
                    (None, None) => 0.0,
                };
                let mut lo = l[k].min(left[k]).min(right[k]);
                let mut hi = l[k].max(left[k]).max(right[k]);
                for v in [up, down].into_iter().flatten() {
                    lo = lo.min(v[k]);
                    hi = hi.max(v[k]);
                }
                let reach = 0.5 * gu.abs() + half_dz * gz.abs();
                let phi = if reach > 0.0 {
                    ((hi - l[k]) / reach).min((l[k] - lo) / reach).min(1.0)
                } else {
                    1.0
                };
                g[0][k] = phi * gu;
                g[1][k] = phi * gz;
            }
            out.push(g);
        }
    }
    out
}

/// A chord's sliver ([`area::PARABOLOID_EDGE_STEPS`]): the signed area in the (U, z) plane
/// (`scale` columns a radian) between the chord from `a` to `b` and the parabola through
/// `a`, the curve's midpoint `m` and `b`, as ∫ z dU along a → b adds it to the polygon's:
/// (2/3)·(ΔU·δz − Δz·δU), δ the midpoint's offset from the chord's. U differences are the
/// angles between the points' (−z, x), so that no column count rounds them (the GPU's fast
/// path counts U from a column next to the texel instead, as precise in float32). Taken from the
/// lesser of `a` and `b` (their coordinates in order) and signed, so that the two texels
/// that share the chord add opposite amounts (glsl/include/convert_area.glsl's `sliver`).
pub(crate) fn sliver(a: DVec3, m: DVec3, b: DVec3, scale: f64) -> f64 {
    let fwd = (a.x, a.y, a.z) <= (b.x, b.y, b.z);
    let (p, q) = if fwd { (a, b) } else { (b, a) };
    let angle = |u: DVec3, v: DVec3| (u.x * v.z - u.z * v.x).atan2(u.z * v.z + u.x * v.x);
    let du = angle(p, q) * scale;
    let du_mid = angle(p, m) * scale - 0.5 * du;
    let dz_mid = m.y - 0.5 * (p.y + q.y);
    let area = 2.0 / 3.0 * (du * dz_mid - (q.y - p.y) * du_mid);
    if fwd {
        area
    } else {
        -area
    }
}

/// A chord's sliver on a paraboloid edge that the rim cuts ([`edge_steps`]): the part of
/// [`sliver`]'s region on the half's side of the rim, z ≥ 0 (`keep_above`) or z ≤ 0, as
/// ∫ z dU along the parabola's kept part less along the chord's (Green's theorem with z
/// clamped at the rim, z = 0 in the (U, z) plane), and the direction of the parabola's point
/// midway along its kept part, whose source texel takes it ([`sliver`] itself, at `m`, where
/// the rim cuts neither). Canonical order and sign as [`sliver`]'s
/// (glsl/include/convert_area.glsl's `sliver_kept`).
pub(crate) fn sliver_kept(
    a: DVec3,
    m: DVec3,
    b: DVec3,
    scale: f64,
    keep_above: bool,
) -> (DVec3, f64) {
    let fwd = (a.x, a.y, a.z) <= (b.x, b.y, b.z);
    let (p, q) = if fwd { (a, b) } else { (b, a) };
    let angle = |u: DVec3, v: DVec3| (u.x * v.z - u.z * v.x).atan2(u.z * v.z + u.x * v.x);
    let (du, du_mid) = (angle(p, q) * scale, angle(p, m) * scale);
    let k = kept_sliver(
        [du, q.y - p.y],
        [du_mid - 0.5 * du, m.y - 0.5 * (p.y + q.y)],
        p.y,
        keep_above,
    );
    let Some((u, z, area)) = k else {
        return (m, 0.0);
    };
    // The kept point's direction, at U = the lesser end's U + u (columns) and z.
    let phi = p.x.atan2(-p.z) + u / scale;
    let r = (1.0 - z * z).max(0.0).sqrt();
    let d = DVec3::new(phi.sin() * r, z, -phi.cos() * r);
    (d, if fwd { area } else { -area })
}

/// [`sliver_kept`] in the chord's frame: the chord from (0, `z0`) by `d`, the parabola's
/// midpoint `o` off the chord's; `None` where nothing of either lies on the kept side, else
/// the kept point's (U from the chord's start, z) and the kept area.
fn kept_sliver(d: [f64; 2], o: [f64; 2], z0: f64, keep_above: bool) -> Option<(f64, f64, f64)> {
    let sign = if keep_above { 1.0 } else { -1.0 };
    // The parabola: U(t) = d.U·t + 4·o.U·t(1 − t), z(t) = a + b·t + c·t²; the chord: o = 0.
    let (a, b, c) = (z0, d[1] + 4.0 * o[1], -4.0 * o[1]);
    let (e, f) = (d[0] + 4.0 * o[0], -8.0 * o[0]);
    let z = |t: f64| a + t * (b + t * c);
    let zc = |t: f64| z0 + t * d[1];
    // Breakpoints where either crosses z = 0 inside the chord.
    let mut ts = vec![0.0, 1.0];
    if d[1] != 0.0 {
        ts.push(-z0 / d[1]);
    }
    if c != 0.0 {
        let disc = b * b - 4.0 * a * c;
        if disc >= 0.0 {
            let h = -0.5 * (b + b.signum() * disc.sqrt());
            ts.push(h / c);
            if h != 0.0 {
                ts.push(a / h);
            }
        }
    } else if b != 0.0 {
        ts.push(-a / b);
    }
    ts.retain(|t| (0.0..=1.0).contains(t));
    ts.sort_by(f64::total_cmp);
    // ∫ z·U' dt's antiderivative along the parabola, and along the chord.
    let big = |t: f64| {
        t * (a * e + t * ((a * f + b * e) / 2.0 + t * ((b * f + c * e) / 3.0 + t * c * f / 4.0)))
    };
    let small = |t: f64| d[0] * t * (z0 + 0.5 * d[1] * t);
    let (mut area, mut kept) = (0.0, None::<(f64, f64)>);
    for w in ts.windows(2) {
        let (t0, t1) = (w[0], w[1]);
        let tm = 0.5 * (t0 + t1);
        if sign * z(tm) > 0.0 {
            area += big(t1) - big(t0);
            kept = Some(kept.map_or((t0, t1), |k| (k.0, t1)));
        }
        if sign * zc(tm) > 0.0 {
            area -= small(t1) - small(t0);
        }
    }
    let (t0, t1) = kept?;
    let t = 0.5 * (t0 + t1);
    Some((d[0] * t + 4.0 * o[0] * t * (1.0 - t), z(t), area))
}

/// Whether direction `d` lies on a pole (the lat-long's Y axis), where U is undefined.
fn on_pole(d: DVec3) -> bool {
    d.x == 0.0 && d.z == 0.0
}

/// The source texel (row, column) of a `w` × `h` lat-long map that takes the sliver whose
/// curve's midpoint is `d`: its row the band (between [`band_edge`]s, as the clip's) that
/// holds z, its U nudged by `area::SLIVER_NUDGE` columns, so that a midpoint on a column's
/// edge by symmetry (x = ±0 on the seam, where atan's sign may differ in float32) lands in
/// one column in both twins.
fn cell_under(d: DVec3, w: i64, h: i64) -> (i64, i64) {
    let u = d.x.atan2(-d.z) * w as f64 / std::f64::consts::TAU + area::SLIVER_NUDGE;
    let z = d.y.clamp(-1.0, 1.0);
    let mut row = ((z.acos() / PI * h as f64).floor() as i64).clamp(0, h - 1);
    if row > 0 && z > band_edge(row, h) {
        row -= 1;
    } else if row < h - 1 && z <= band_edge(row + 1, h) {
        row += 1;
    }
    (row, (u.floor() as i64).rem_euclid(w))
}

/// A texel's footprint in the (U, z) plane ([`area_polygon`]): its polygon and its chords'
/// slivers, each with the direction whose source texel takes it.
pub(crate) struct Footprint {
    pub poly: Vec<[f64; 2]>,
    pub slivers: Vec<(DVec3, f64)>,
}

/// Which slivers an edge's chords take ([`edge_steps`]).
#[derive(Clone, Copy, PartialEq, Debug)]
enum Slivers {
    /// None: the chords alone.
    None,
    /// Each chord's whole sliver ([`sliver`]).
    Whole,
    /// Each chord's sliver on its half's side of the rim ([`sliver_kept`]).
    Kept,
}

/// Points along an edge of a `to` texel of side `n` (its ends `e` in integer texel
/// coordinates, `ends` their directions), and which slivers its chords take: on a
/// paraboloid, [`area::POLE_STEPS`] chords where its nearer end is near the pole's axis (where
/// z = cos θ bends most), else `edge_points` where both ends lie in the disc and
/// [`area::PARABOLOID_RIM_STEPS`] where one lies outside; whole slivers where both ends lie
/// in the disc, else their parts inside the half; a cube's [`area::EDGE_STEPS`], or
/// [`area::POLE_STEPS`] near a pole, with slivers below [`area::FAST_MIN_SIZE`], where every
/// texel takes the general walk (the fast path has none, so above that size neither side of
/// an edge takes them). Decided from the edge alone, so that both texels that share it agree.
fn edge_steps(
    to: Mapping,
    n: u32,
    e: [(u32, u32); 2],
    ends: [DVec3; 2],
    edge_points: u32,
) -> (u32, Slivers) {
    let reach = ends[0].x.hypot(ends[0].z).min(ends[1].x.hypot(ends[1].z));
    let near = reach < area::POLE_NEAR / n as f64;
    if to != Mapping::DualParaboloid {
        // Slivers where every texel takes the general walk: the fast path has none.
        let m = if near {
            area::POLE_STEPS
        } else {
            area::EDGE_STEPS
        };
        let slivers = if n < area::FAST_MIN_SIZE {
            Slivers::Whole
        } else {
            Slivers::None
        };
        return (m, slivers);
    }
    let inside = |(a, b): (u32, u32)| {
        let (s, t, n) = (2 * a as i64 - n as i64, 2 * b as i64 - n as i64, n as i64);
        s * s + t * t <= n * n
    };
    match (inside(e[0]) && inside(e[1]), near) {
        (true, true) => (area::POLE_STEPS, Slivers::Whole),
        (true, false) => (edge_points, Slivers::Whole),
        (false, true) => (area::POLE_STEPS, Slivers::Kept),
        (false, false) => (area::PARABOLOID_RIM_STEPS, Slivers::Kept),
    }
}

/// The footprint of texel (face, i, j) of a `to` map of side `n` (a cube or a dual
/// paraboloid) in the (U, z) plane of a `w`-wide lat-long map: a polygon of at most
/// [`area::MAX_VERTICES`] vertices, U unwrapped continuously from the first point, and its
/// slivers ([`edge_steps`]).
#[allow(clippy::too_many_arguments)]
fn area_polygon(
    to: Mapping,
    face: u32,
    i: u32,
    j: u32,
    n: u32,
    w: i64,
    world_to_file: DMat3,
    edge_points: u32,
) -> Footprint {
    // Boundary points: the corners and m − 1 points along each edge (straight lines in the
    // map's (s, t): great circles for a cube, circles for a paraboloid), from integer
    // coordinates so that the neighbour sharing an edge computes the same points.
    let steps = [(0, 0), (1, 0), (1, 1), (0, 1)];
    let point = |a: u32, b: u32, m: u32| {
        let c = Coord {
            layer: face,
            u: a as f64 / (n * m) as f64,
            v: b as f64 / (n * m) as f64,
        };
        world_to_file * to.coord_to_dir(c)
    };
    let scale = w as f64 / std::f64::consts::TAU;
    let mut ds = Vec::with_capacity(area::MAX_VERTICES as usize);
    let mut slivers = Vec::new();
    for k in 0..4 {
        let (a0, b0) = steps[k];
        let (a1, b1) = steps[(k + 1) % 4];
        let e = [(i + a0, j + b0), (i + a1, j + b1)];
        let ends = [point(e[0].0, e[0].1, 1), point(e[1].0, e[1].1, 1)];
        let (m, kind) = edge_steps(to, n, e, ends, edge_points);
        let at = |q: u32, m: u32| {
            point(
                e[0].0 * (m - q) + e[1].0 * q,
                e[0].1 * (m - q) + e[1].1 * q,
                m,
            )
        };
        for q in 0..m {
            let (a, b) = (at(q, m), at(q + 1, m));
            ds.push(a);
            // The chord from point q to q + 1; its curve's midpoint is point 2q + 1 of 2m. A
            // chord from a pole is a meridian, and the polygon meets the pole's line there.
            if kind != Slivers::None && !on_pole(a) && !on_pole(b) {
                let mid = at(2 * q + 1, 2 * m);
                slivers.push(match kind {
                    Slivers::Kept => sliver_kept(a, mid, b, scale, face == 0),
                    _ => (mid, sliver(a, mid, b, scale)),
                });
            }
        }
    }
    let count = ds.len();
    let wf = w as f64;
    let wrap = |d: f64| d - wf * (d / wf).round();
    // U of each point, unwrapped against the previous point off the pole.
    let mut us = vec![0.0f64; count];
    let mut prev: Option<f64> = None;
    for k in 0..count {
        if on_pole(ds[k]) {
            continue;
        }
        let u = ds[k].x.atan2(-ds[k].z) * scale;
        us[k] = match prev {
            Some(p) => p + wrap(u - p),
            None => u,
        };
        prev = Some(us[k]);
    }
    let mut poly = Vec::with_capacity(count + 3);
    let mut pole = false;
    for k in 0..count {
        if on_pole(ds[k]) {
            // The edges to a pole are meridians: the footprint meets the pole's line from
            // the previous point's U to the next point's.
            pole = true;
            let (p, q) = ((k + count - 1) % count, (k + 1) % count);
            let zp = ds[k].y.signum();
            poly.push([us[p], zp]);
            poly.push([us[q], zp]);
        } else {
            poly.push([us[k], ds[k].y]);
        }
    }
    if !pole {
        // A texel that holds a pole winds once around it: close it along the pole's line.
        let (first, last) = (us[0], us[count - 1]);
        let closed = last + wrap(first - last);
        if (closed - first).abs() > 0.5 * wf {
            // A paraboloid texel can hold only its own half's pole (the other is at infinity
            // in (s, t)), and its boundary may lie past the rim, in the other hemisphere.
            let zp = match to {
                Mapping::DualParaboloid if face == 0 => 1.0,
                Mapping::DualParaboloid => -1.0,
                _ => ds[0].y.signum(),
            };
            poly.push([closed, ds[0].y]);
            poly.push([closed, zp]);
            poly.push([first, zp]);
        }
    }
    Footprint { poly, slivers }
}

/// The mean of the reconstructed source `cell(row, col)` over polygon `poly` in the (U, z)
/// plane of a `w` × `h` lat-long map (U may run past [0, w): columns wrap): the pieces
/// [`area_walk`] finds, summed.
fn area_mean(f: &Footprint, w: i64, h: i64, cell: impl Fn(i64, i64) -> Cell) -> [f32; 3] {
    let poly = &f.poly;
    // Sums of (L − L0), as the GLSL (where a constant map then comes out exact). L0 is the
    // least, per channel, of the texels under the polygon's points: a texel that merely
    // touches the footprint may be a sun 1e5 × the mean, whose cancellation would cost float32
    // (the GLSL) its digits; the least is at most the mean.
    let mut l0 = [f64::MAX; 3];
    for (row, col) in point_cells(poly, w, h) {
        let t = cell(row, col).l;
        for ch in 0..3 {
            l0[ch] = l0[ch].min(t[ch]);
        }
    }
    let (mut num, mut den) = ([0.0f64; 3], 0.0f64);
    area_walk(poly, w, h, |row, col, [area, mu, mz]| {
        let t = cell(row, col);
        for ch in 0..3 {
            num[ch] += (t.l[ch] - l0[ch]) * area + t.slopes[0][ch] * mu + t.slopes[1][ch] * mz;
        }
        den += area;
    });
    // The slivers: each its area at the mean of the source texel under its curve's midpoint.
    for &(d, area) in &f.slivers {
        let (row, col) = cell_under(d, w, h);
        let t = cell(row, col);
        for ch in 0..3 {
            num[ch] += (t.l[ch] - l0[ch]) * area;
        }
        den += area;
    }
    if den == 0.0 {
        return l0.map(|x| x as f32);
    }
    std::array::from_fn(|ch| ((l0[ch] + num[ch] / den) as f32).max(0.0))
}

/// The (row, column) of the source texel under each point of `poly`.
fn point_cells(poly: &[[f64; 2]], w: i64, h: i64) -> impl Iterator<Item = (i64, i64)> + '_ {
    let hf = h as f64;
    poly.iter().map(move |p| {
        let row = ((p[1].clamp(-1.0, 1.0).acos() / PI * hf).floor() as i64).clamp(0, h - 1);
        (row, (p[0].floor() as i64).rem_euclid(w))
    })
}

/// Polygon `poly`'s overlap with each source texel of a `w` × `h` lat-long map in the (U, z)
/// plane, piece by piece: per band and column, each clipped edge's piece of ∫∫ 1, ∫∫ (U − Uc)
/// and ∫∫ (z − zc) over the overlap (Green's theorem; Simpson's rule, exact for these
/// quadratics), handed to `piece(row, col, [area, mu, mz])` (col wrapped into [0, w)).
fn area_walk(poly: &[[f64; 2]], w: i64, h: i64, mut piece: impl FnMut(i64, i64, [f64; 3])) {
    let (mut zmin, mut zmax) = (f64::MAX, f64::MIN);
    for p in poly {
        zmin = zmin.min(p[1]);
        zmax = zmax.max(p[1]);
    }
    let hf = h as f64;
    let row_of = |z: f64| ((z.clamp(-1.0, 1.0).acos() / PI * hf).floor() as i64).clamp(0, h - 1);
    // The rows the polygon meets, by the same band edges as the clip (acos alone is coarse
    // near the poles in float32).
    let (mut r0, mut r1) = (row_of(zmax), row_of(zmin));
    while r0 > 0 && band_edge(r0, h) < zmax {
        r0 -= 1;
    }
    while r0 < r1 && band_edge(r0 + 1, h) >= zmax {
        r0 += 1;
    }
    while r1 < h - 1 && band_edge(r1 + 1, h) > zmin {
        r1 += 1;
    }
    while r1 > r0 && band_edge(r1, h) <= zmin {
        r1 -= 1;
    }
    for row in r0..=r1 {
        let zhi = band_edge(row, h);
        let zlo = band_edge(row + 1, h);
        let zc = 0.5 * (zhi + zlo);
        let band = clip_band(poly, zlo, zhi);
        let n = band.len();
        for k in 0..n {
            let (a, b) = (band[k], band[(k + 1) % n]);
            // Canonical order: the same pieces from both texels that share the edge.
            let (p, q, sign) = if (a[0], a[1]) <= (b[0], b[1]) {
                (a, b, 1.0)
            } else {
                (b, a, -1.0)
            };
            if p[0] == q[0] {
                continue;
            }
            let z = |u: f64| p[1] + (q[1] - p[1]) * ((u - p[0]) / (q[0] - p[0]));
            let mut c = p[0].floor() as i64;
            loop {
                let u0 = p[0].max(c as f64);
                let u1 = q[0].min((c + 1) as f64);
                if u1 > u0 {
                    let um = 0.5 * (u0 + u1);
                    let (z0, zm, z1) = (z(u0), z(um), z(u1));
                    let d = sign * (u1 - u0);
                    let uc = c as f64 + 0.5;
                    let area = d * (0.5 * (z0 + z1) - zlo);
                    let fu = |u: f64, zz: f64| (u - uc) * (zz - zlo);
                    let mu = d / 6.0 * (fu(u0, z0) + 4.0 * fu(um, zm) + fu(u1, z1));
                    let base = (zlo - zc) * (zlo - zc);
                    let fz = |zz: f64| 0.5 * ((zz - zc) * (zz - zc) - base);
                    let mz = d / 6.0 * (fz(z0) + 4.0 * fz(zm) + fz(z1));
                    piece(row, c.rem_euclid(w), [area, mu, mz]);
                }
                c += 1;
                if c as f64 >= q[0] {
                    break;
                }
            }
        }
    }
}

/// z = cos θ at the top of lat-long row `row` of `h` (row `h`: the south pole).
fn band_edge(row: i64, h: i64) -> f64 {
    if row <= 0 {
        1.0
    } else if row >= h {
        -1.0
    } else {
        (PI * row as f64 / h as f64).cos()
    }
}

/// `pts` clipped to z ≥ bound (`keep_above`) or z ≤ bound (Sutherland–Hodgman, intersections
/// from a canonical endpoint order, so that two polygons sharing an edge cut it at one point).
fn cut(pts: &[[f64; 2]], bound: f64, keep_above: bool) -> Vec<[f64; 2]> {
    let inside = |p: &[f64; 2]| {
        if keep_above {
            p[1] >= bound
        } else {
            p[1] <= bound
        }
    };
    let mut out = Vec::with_capacity(pts.len() + 2);
    let n = pts.len();
    for k in 0..n {
        let (a, b) = (pts[k], pts[(k + 1) % n]);
        let (ia, ib) = (inside(&a), inside(&b));
        if ia {
            out.push(a);
        }
        if ia != ib {
            let (p, q) = if (a[0], a[1]) <= (b[0], b[1]) {
                (a, b)
            } else {
                (b, a)
            };
            let t = (bound - p[1]) / (q[1] - p[1]);
            out.push([p[0] + (q[0] - p[0]) * t, bound]);
        }
    }
    out
}

/// `poly` clipped to zlo ≤ z ≤ zhi.
fn clip_band(poly: &[[f64; 2]], zlo: f64, zhi: f64) -> Vec<[f64; 2]> {
    cut(&cut(poly, zlo, true), zhi, false)
}

#[cfg(test)]
mod tests;

/// How [`reduce_to_fit`] reduced a map.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Reduction {
    /// The means of k × k blocks of texels (each block's power kept exactly).
    Blocks(u32),
    /// A supersampled conversion to the same mapping, scaled to the map's power per channel
    /// (no block size near enough divides both sides).
    Resampled,
}

/// `map` reduced so that no side exceeds `max_side` (a device's largest image side, or a
/// cube's face), its power kept: the means of k × k blocks for the smallest k that brings it
/// within `max_side` and divides both sides (lat-long and cube, k at most twice the least
/// reduction), else a conversion to the same mapping at `max_side` with one sample per
/// source texel spacing and one more per axis, scaled to the map's power per channel.
/// `None` where it fits.
pub fn reduce_to_fit(map: &EnvMap, max_side: u32) -> Option<(EnvMap, Reduction)> {
    let side = map.width.max(map.height);
    if side <= max_side || max_side == 0 {
        return None;
    }
    let need = side.div_ceil(max_side);
    let blocks = (need..=2 * need)
        .find(|k| map.width.is_multiple_of(*k) && map.height.is_multiple_of(*k))
        .and_then(|k| {
            let (m, _) = super::lights::block_means(map, k, f64::INFINITY)?;
            Some((m, Reduction::Blocks(k)))
        });
    if blocks.is_some() {
        return blocks;
    }
    // A lat-long's size is its width (its height half of it); the others' their side.
    let (w, _) = map.mapping.extent_for_size(max_side);
    let ss = (map.width.div_ceil(w) + 1).clamp(2, 16);
    let mut out = convert(map, map.mapping, max_side, DMat3::IDENTITY, ss);
    let (want, got) = (map.power(), out.power());
    let scale = [0, 1, 2].map(|c| {
        if got[c] > 0.0 {
            (want[c] / got[c]) as f32
        } else {
            1.0
        }
    });
    for t in &mut out.texels {
        for c in 0..3 {
            t[c] *= scale[c];
        }
    }
    Some((out, Reduction::Resampled))
}

#[cfg(test)]
mod reduce_tests {
    use super::*;
    use crate::math::synth::Sky;

    /// The split conversion's tile lists cover every fast texel and every texel outside a
    /// paraboloid's disc, and hold no tile without one; at 512² a paraboloid's fast path
    /// leaves out a fifth of its tiles.
    #[test]
    fn tiles_cover_the_fast_and_rim_texels_and_no_more() {
        let [tw, th] = crate::abi::WORKGROUP_2D;
        for to in [Mapping::Cube, Mapping::DualParaboloid] {
            for n in [13, 32, 40, 67, 128] {
                let (fast, rim) = area_tiles(to, n);
                let tile = |i: u32, j: u32, layer: u32| [i / tw, j / th, layer, 0];
                let (mut want_fast, mut want_rim) = (Vec::new(), Vec::new());
                for layer in 0..to.layers() {
                    for j in 0..n {
                        for i in 0..n {
                            if !area_general_texel(to, layer, i, j, n) {
                                want_fast.push(tile(i, j, layer));
                            }
                            if !to.texel_in_domain(n, n, i, j) {
                                want_rim.push(tile(i, j, layer));
                            }
                        }
                    }
                }
                want_fast.dedup();
                want_fast.sort();
                want_fast.dedup();
                want_rim.sort();
                want_rim.dedup();
                let (mut fast, mut rim) = (fast.clone(), rim.clone());
                fast.sort();
                rim.sort();
                assert_eq!(fast, want_fast, "{to:?} {n}: fast tiles");
                assert_eq!(rim, want_rim, "{to:?} {n}: rim tiles");
                assert_eq!(rim.is_empty(), to == Mapping::Cube, "{to:?} {n}");
            }
        }
        let (fast, _) = area_tiles(Mapping::DualParaboloid, 512);
        let all = 2 * (512 / tw) * (512 / th);
        let left = 1.0 - fast.len() as f64 / all as f64;
        assert!((0.15..0.25).contains(&left), "{left}");
    }

    fn rel(a: f64, b: f64) -> f64 {
        (a - b).abs() / b.abs().max(1e-300)
    }

    /// Blocks where a block size near the least reduction divides both sides (64 × 32 to
    /// 20: k = 4, 16 × 8; a 48² cube face to 20: k = 3), a resampling where none does (46 ×
    /// 23 to 20: no k from 3 to 6 divides 23): the sides within the limit, the power per
    /// channel kept to 1e-6, the sun's texel still the brightest within 1.5 texels of its
    /// direction; nothing where the map fits.
    #[test]
    fn reduced_maps_fit_and_keep_their_power() {
        let sky = Sky::default();
        let cases = [
            (Mapping::LatLong, 64, 32, 20, Some(Reduction::Blocks(4))),
            (Mapping::Cube, 48, 48, 20, Some(Reduction::Blocks(3))),
            (Mapping::LatLong, 46, 23, 20, Some(Reduction::Resampled)),
            (Mapping::LatLong, 64, 32, 64, None),
        ];
        for (mapping, w, h, max, how) in cases {
            let map = EnvMap::from_fn(mapping, w, h, 2, move |d| sky.radiance(d));
            let got = reduce_to_fit(&map, max);
            assert_eq!(
                got.as_ref().map(|g| g.1),
                how,
                "{mapping:?} {w}x{h} to {max}"
            );
            let Some((small, _)) = got else { continue };
            assert!(small.width <= max && small.height <= max, "{mapping:?}");
            assert_eq!(small.mapping, mapping);
            let (a, b) = (small.power(), map.power());
            for c in 0..3 {
                assert!(
                    rel(a[c], b[c]) < 1e-6,
                    "{mapping:?} {w}x{h}: power {a:?} against {b:?}"
                );
            }
            let brightest = |m: &EnvMap| {
                let k = (0..m.texels.len())
                    .max_by(|&x, &y| {
                        let l = |t: [f32; 3]| t[0] as f64 + t[1] as f64 + t[2] as f64;
                        l(m.texels[x]).total_cmp(&l(m.texels[y]))
                    })
                    .unwrap();
                let (w, h) = (m.width as usize, m.height as usize);
                m.texel_dir((k / (w * h)) as u32, (k % w) as u32, (k / w % h) as u32)
            };
            let angle = brightest(&small)
                .dot(brightest(&map))
                .clamp(-1.0, 1.0)
                .acos();
            let texel = std::f64::consts::PI / small.height as f64;
            assert!(
                angle < 1.5 * texel,
                "{mapping:?} {w}x{h}: the sun moved {angle} rad"
            );
        }
    }
}
