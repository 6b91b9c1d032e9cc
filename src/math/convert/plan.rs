//! The exact-area conversion's weights, planned once for a source size, an output mapping and
//! size, an orientation and the points per paraboloid texel edge: per output texel, the source
//! texels its footprint overlaps and, for each, the overlap's area and first moments over the
//! footprint's area. Applying them to a map (`glsl/convert_planned.comp`; here
//! [`apply_area_plan`]) is [`super::latlong_area_points`] without the geometry: a gather of a
//! handful of texels and their slopes per output texel. Weights are the float64 walk's, merged
//! per source texel and rounded once to float32.

use super::{area_polygon, area_walk, cell_under, cut, point_cells, rim_nearest, Mapping};
use crate::abi::area;
use crate::math::envmap::EnvMap;
use glam::DMat3;

/// One source texel's share of an output texel: its column and row packed
/// `col | row << area::PLAN_ROW_SHIFT`,
/// then the overlap's ∫∫ 1, ∫∫ (U − Uc) and ∫∫ (z − zc) over the footprint's ∫∫ 1 (bit patterns
/// of float32), the layout `glsl/convert_planned.comp` reads as a `uvec4`.
pub type PlanEntry = [u32; 4];

/// What [`area_plan`] computes: output texel t (layer-major, then row, then column) takes
/// entries `offsets[t] .. offsets[t + 1]`.
#[derive(Clone, Debug, PartialEq)]
pub struct AreaPlan {
    /// Source width and height.
    pub src: (u32, u32),
    /// Output mapping (cube or dual paraboloid).
    pub to: Mapping,
    /// Output size (`Mapping::extent_for_size`).
    pub size: u32,
    /// Per output texel, its first entry; one more at the end (the entry count).
    pub offsets: Vec<u32>,
    /// The entries, output texel by output texel.
    pub entries: Vec<PlanEntry>,
}

impl AreaPlan {
    /// Bytes the plan takes on the GPU (offsets and entries).
    pub fn bytes(&self) -> u64 {
        4 * self.offsets.len() as u64 + 16 * self.entries.len() as u64
    }
}

/// The entry of source texel (row, col) with weights `w`.
fn entry(row: i64, col: i64, w: [f64; 3]) -> PlanEntry {
    let cell = col as u32 | (row as u32) << area::PLAN_ROW_SHIFT;
    [
        cell,
        (w[0] as f32).to_bits(),
        (w[1] as f32).to_bits(),
        (w[2] as f32).to_bits(),
    ]
}

/// The entries of output texel (layer, i, j): its footprint's overlaps merged per source
/// texel, over its area; a paraboloid texel outside its disc (or inside it by less than the
/// chords' error), and a footprint of no area, the one source texel the twin takes whole.
#[allow(clippy::too_many_arguments)]
fn texel_entries(
    (w, h): (i64, i64),
    to: Mapping,
    size: u32,
    world_to_file: DMat3,
    edge_points: u32,
    (layer, i, j): (u32, u32, u32),
    out: &mut Vec<PlanEntry>,
) {
    let (ow, oh) = to.extent_for_size(size);
    let nearest = |out: &mut Vec<PlanEntry>| {
        let c = rim_nearest(ow, oh, layer, i, j);
        let d = world_to_file * to.coord_to_dir(c);
        let s = Mapping::LatLong.dir_to_coord(d);
        let col = ((s.u * w as f64).floor() as i64).clamp(0, w - 1);
        let row = ((s.v * h as f64).floor() as i64).clamp(0, h - 1);
        out.push(entry(row, col, [1.0, 0.0, 0.0]));
    };
    if !to.texel_in_domain(ow, oh, i, j) {
        return nearest(out);
    }
    let mut f = area_polygon(to, layer, i, j, size, w, world_to_file, edge_points);
    if to == Mapping::DualParaboloid {
        f.poly = cut(&f.poly, 0.0, layer == 0);
    }
    let poly = &f.poly;
    if poly.len() < 3 {
        return nearest(out);
    }
    let mut cells: Vec<((i64, i64), [f64; 3])> = Vec::with_capacity(16);
    let mut den = 0.0;
    let mut add = |row, col, m: [f64; 3]| {
        den += m[0];
        match cells.iter_mut().find(|(c, _)| *c == (row, col)) {
            Some((_, s)) => (0..3).for_each(|k| s[k] += m[k]),
            None => cells.push(((row, col), m)),
        }
    };
    area_walk(poly, w, h, &mut add);
    for &(d, area) in &f.slivers {
        let (row, col) = cell_under(d, w, h);
        add(row, col, [area, 0.0, 0.0]);
    }
    if den == 0.0 {
        // No area: the texel under its first point (the twin takes the least under all).
        let (row, col) = point_cells(poly, w, h).next().unwrap_or((0, 0));
        out.push(entry(row, col, [1.0, 0.0, 0.0]));
        return;
    }
    cells.sort_by_key(|(c, _)| *c);
    for ((row, col), m) in cells {
        out.push(entry(row, col, m.map(|x| x / den)));
    }
}

/// Plans the exact-area conversion of a `width` × `height` lat-long map to `to` at `size`,
/// oriented by `world_to_file`, with `edge_points` points per paraboloid texel edge (see
/// [`super::latlong_area_points`], which it reproduces to float32 weights), on every core.
/// Panics where [`super::area_serves`] refuses the conversion, or the source is wider or
/// taller than 2^`area::PLAN_ROW_SHIFT` texels.
pub fn area_plan(
    (width, height): (u32, u32),
    to: Mapping,
    size: u32,
    world_to_file: DMat3,
    edge_points: u32,
) -> AreaPlan {
    assert!((1..=area::POLE_STEPS).contains(&edge_points));
    let most = 1 << area::PLAN_ROW_SHIFT;
    assert!(
        width <= most && height <= most,
        "source too large for a plan"
    );
    assert!(
        super::area_serves(1, 1, to, size.max(1), world_to_file),
        "no area conversion to {to:?} with this orientation"
    );
    let (ow, oh) = to.extent_for_size(size);
    let rows = to.layers() * oh;
    let threads = std::thread::available_parallelism().map_or(1, |n| n.get()) as u32;
    let chunk = rows.div_ceil(threads.max(1)).max(1);
    let parts: Vec<(Vec<u32>, Vec<PlanEntry>)> = std::thread::scope(|s| {
        let jobs: Vec<_> = (0..rows)
            .step_by(chunk as usize)
            .map(|r0| {
                s.spawn(move || {
                    let (mut counts, mut entries) = (Vec::new(), Vec::new());
                    for r in r0..(r0 + chunk).min(rows) {
                        let (layer, j) = (r / oh, r % oh);
                        for i in 0..ow {
                            let before = entries.len();
                            let src = (width as i64, height as i64);
                            let at = (layer, i, j);
                            texel_entries(
                                src,
                                to,
                                size,
                                world_to_file,
                                edge_points,
                                at,
                                &mut entries,
                            );
                            counts.push((entries.len() - before) as u32);
                        }
                    }
                    (counts, entries)
                })
            })
            .collect();
        jobs.into_iter()
            .map(|j| j.join().unwrap_or_else(|p| std::panic::resume_unwind(p)))
            .collect()
    });
    let mut offsets = Vec::with_capacity((rows * ow) as usize + 1);
    let mut entries = Vec::new();
    for (counts, part) in parts {
        let mut at = entries.len() as u32;
        for c in counts {
            offsets.push(at);
            at += c;
        }
        entries.extend(part);
    }
    offsets.push(entries.len() as u32);
    AreaPlan {
        src: (width, height),
        to,
        size,
        offsets,
        entries,
    }
}

/// Applies `plan` to `map` in float64: each output texel the sum of its entries' weights times
/// the source texel's value and limited slopes ([`super::area_slopes`]), never negative.
/// Panics unless `map` is a lat-long map of the plan's source size.
pub fn apply_area_plan(plan: &AreaPlan, map: &EnvMap) -> EnvMap {
    assert_eq!(map.mapping, Mapping::LatLong);
    assert_eq!(
        (map.width, map.height),
        plan.src,
        "the map is not the plan's size"
    );
    let slopes = super::area_slopes(map);
    let w = map.width as usize;
    let texels = plan
        .offsets
        .windows(2)
        .map(|o| {
            let mut sum = [0.0f64; 3];
            for e in &plan.entries[o[0] as usize..o[1] as usize] {
                let low = (1 << area::PLAN_ROW_SHIFT) - 1;
                let (col, row) = (
                    (e[0] & low) as usize,
                    (e[0] >> area::PLAN_ROW_SHIFT) as usize,
                );
                let [a, mu, mz] = [e[1], e[2], e[3]].map(|b| f32::from_bits(b) as f64);
                let (l, g) = (map.texels[row * w + col], slopes[row * w + col]);
                for k in 0..3 {
                    sum[k] += a * l[k] as f64 + mu * g[0][k] + mz * g[1][k];
                }
            }
            sum.map(|x| (x as f32).max(0.0))
        })
        .collect();
    let (ow, oh) = plan.to.extent_for_size(plan.size);
    EnvMap::new(plan.to, ow, oh, texels)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::Orientation;

    /// A plan applied in float64 is the twin's conversion but for the weights' rounding to
    /// float32 (~6e-8 each, all but the slopes' positive): within 1e-6 of each texel, on a
    /// smooth map with two suns 10⁵ × the sky (one on the seam), to cube and paraboloid at
    /// tiny, odd and fast-path sizes, turned and flipped, at 2 and 8 points per paraboloid
    /// edge. Every texel's area weights sum to 1 (to float32), and a plan is refused a map of
    /// another size.
    #[test]
    fn a_plan_applied_is_the_twin() {
        let (w, h) = (96u32, 48u32);
        let mut src = EnvMap::from_fn(Mapping::LatLong, w, h, 1, |d| {
            let s = (13.0 * d.x + 7.0 * d.y).sin();
            [
                1.0 + 0.5 * s,
                1.0 + 0.5 * (9.0 * d.z).cos(),
                1.25 + 0.75 * d.y,
            ]
        });
        src.texels[(h as usize / 3) * w as usize] = [1e5, 2e5, 5e4];
        src.texels[(h as usize / 2) * w as usize + 40] = [3e5, 1e5, 1e5];
        let turned = Orientation {
            flip_u: true,
            flip_v: false,
            rotate_y_degrees: 33.0,
        };
        let mut worst = 0.0f64;
        for (to, size, o, points) in [
            (Mapping::Cube, 1, Orientation::default(), 8),
            (Mapping::Cube, 7, Orientation::default(), 8),
            (Mapping::Cube, 40, turned, 8),
            (Mapping::DualParaboloid, 1, Orientation::default(), 8),
            (Mapping::DualParaboloid, 13, turned, 8),
            (Mapping::DualParaboloid, 40, Orientation::default(), 2),
            (Mapping::DualParaboloid, 33, Orientation::default(), 8),
        ] {
            let w2f = o.world_to_file();
            let plan = area_plan((w, h), to, size, w2f, points);
            let got = apply_area_plan(&plan, &src);
            let want = super::super::latlong_area_points(&src, to, size, w2f, points);
            assert_eq!((got.width, got.height), (want.width, want.height));
            for (t, (a, b)) in got.texels.iter().zip(&want.texels).enumerate() {
                for k in 0..3 {
                    let e = (a[k] as f64 - b[k] as f64).abs() / (b[k] as f64).abs().max(1e-30);
                    assert!(e <= 1e-6, "{to:?} {size} texel {t}: {a:?} vs {b:?}");
                    worst = worst.max(e);
                }
            }
            for o in plan.offsets.windows(2) {
                let sum: f64 = plan.entries[o[0] as usize..o[1] as usize]
                    .iter()
                    .map(|e| f32::from_bits(e[1]) as f64)
                    .sum();
                assert!(
                    (sum - 1.0).abs() <= 1e-6,
                    "{to:?} {size}: weights sum to {sum}"
                );
            }
        }
        eprintln!("plan applied vs twin: worst {worst:.2e}");
        let plan = area_plan((w, h), Mapping::Cube, 4, DMat3::IDENTITY, 8);
        let other = EnvMap::from_fn(Mapping::LatLong, 32, 16, 1, |_| [1.0; 3]);
        let refused = std::panic::catch_unwind(|| apply_area_plan(&plan, &other));
        assert!(refused.is_err());
    }
}
