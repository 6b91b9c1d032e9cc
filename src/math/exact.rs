//! Float64 filters of a map over every texel, for spot checks of baked cubes: split-sum's
//! GGX chain kernel at n = v = r ([`super::split_sum::chain_kernel`]) and the clamped cosine
//! (irradiance); and, for a reference with no noise, the radiance any BRDF reflects at a
//! surface of normal n seen along v ([`ExactFilter::shade`]). The map is taken as what it stores, constant radiance over each texel, as in
//! [`super::filter`]; unlike that module's per-texel rules these sums never skip a texel, as
//! GGX's tail (∝ θ⁻⁴) reaches the whole sphere.
//!
//! Nothing is stored per texel: each texel's direction and solid angle are found as the sums
//! visit it, rows at a time on every core, and [`ExactFilter::evaluate`] takes every query of
//! a check in one pass over the map (a bake's check of an 8k map holds no copy of it).

use super::brdf::{local_view, Brdf, Frame};
use super::lights::lobe_scale;
use super::mapping::{Coord, Mapping};
use super::split_sum::chain_kernel;
use crate::abi::exact::{HORIZON_REACH, HORIZON_SHRINK, MAX_CELLS_PER_WIDTH};
use crate::abi::lights::{CENTRE_BELOW, TAIL_FRACTION};
use crate::EnvMap;
use glam::{DMat3, DVec3};

/// One texel that holds part of the sphere.
struct Texel {
    layer: u32,
    i: u32,
    j: u32,
    /// Centre direction (world).
    dir: DVec3,
    /// Exact solid angle.
    omega: f64,
    /// Its square root, the texel's angular size.
    rho: f64,
    radiance: [f64; 3],
    /// A bound on the chord from its centre to any of its points (∞ where not known): no
    /// point of a texel whose centre lies further than this below a surface's horizon is
    /// above it.
    reach: f64,
    /// A lat-long texel's centre (sin θ, cos θ, sin φ, cos φ), from which its Gauss points'
    /// directions follow by angle addition ([`ExactFilter::cell_mean`]); `None` elsewhere.
    angles: Option<[f64; 4]>,
}

/// One filter value [`ExactFilter::evaluate`] finds.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Query {
    /// [`ExactFilter::ggx`] at world direction `r`.
    Ggx {
        /// The lobe's axis (world).
        r: DVec3,
        /// GGX α.
        alpha: f64,
    },
    /// [`ExactFilter::irradiance`] at world normal `n`.
    Irradiance {
        /// The normal (world).
        n: DVec3,
    },
    /// [`ExactFilter::shade`]: the radiance a BRDF reflects.
    Shade {
        /// The BRDF (F = 1).
        brdf: Brdf,
        /// The surface normal (world, unit).
        n: DVec3,
        /// Towards the eye (world, unit).
        v: DVec3,
    },
}

/// A [`Query`] with what its sums use at every texel found once.
#[derive(Clone, Copy)]
enum Prepared {
    Ggx { r: DVec3, r_file: DVec3, a: f64 },
    Irradiance { n: DVec3 },
    Shade(ShadeLobe),
}

/// A [`Query::Shade`] prepared: the BRDF in the surface's frame, its lobe's axis and scale.
#[derive(Clone, Copy)]
struct ShadeLobe {
    brdf: Brdf,
    frame: Frame,
    /// The view in the frame (lifted above the horizon as `fis::estimate` lifts it).
    wo: DVec3,
    /// The lobe's axis (world): the reflected direction, the normal for the diffuse lobe.
    axis: DVec3,
    /// The lobe's angular scale ([`lobe_scale`]); `None`: a mirror.
    scale: Option<f64>,
    /// The texel (layer, i, j) the reflected direction falls in (a mirror's lobe).
    reflected: (u32, u32, u32),
    /// How much narrower than its scale the lobe is across the plane of incidence: a
    /// specular lobe reflected off a grazing view is squeezed by 2·(n·v) there (dω_i =
    /// 4(h·v)·dω_h with h near n), so its cells shrink with it; 1 for the diffuse lobe.
    squeeze: f64,
}

impl ShadeLobe {
    /// The lobe of `brdf` at normal `n` seen along `v` (world, unit); its reflected texel
    /// is set by [`ExactFilter::shade_lobe`].
    fn new(brdf: Brdf, n: DVec3, v: DVec3) -> ShadeLobe {
        let frame = Frame::new(n);
        let wo = local_view(&frame, v);
        let axis = match brdf {
            Brdf::Lambert => n,
            _ => frame.to_world(DVec3::new(-wo.x, -wo.y, wo.z)),
        };
        ShadeLobe {
            brdf,
            frame,
            wo,
            axis,
            scale: lobe_scale(&brdf),
            reflected: (0, 0, 0),
            squeeze: match brdf {
                Brdf::Lambert => 1.0,
                _ => (2.0 * wo.z).clamp(0.02, 1.0),
            },
        }
    }

    /// The scale its texels' rule starts from: [`lobe_scale`] capped at
    /// [`SHADE_SCALE_MAX`], squeezed at grazing views; `None` for a mirror.
    fn rule_scale(&self) -> Option<f64> {
        self.scale.map(|a| a.min(SHADE_SCALE_MAX) * self.squeeze)
    }
}

/// Gauss cells per lobe scale in [`ExactFilter::shade`]'s texel rule.
pub const PER_WIDTH: f64 = 4.0;

/// The lobe of a [`Query::Shade`] as the GPU's exact pass reads it
/// (`glsl/exact_shade.comp`, [`crate::passes::ExactShader`]): the surface's tangent,
/// bitangent and normal, the lobe's axis (each turned into the map's file frame by
/// `world_to_file`), the view in the surface's frame, and in the last word the scale its
/// texels' rule starts from; `None` for a mirror, whose lobe is no integral.
pub fn gpu_lobe(brdf: Brdf, n: DVec3, v: DVec3, world_to_file: DMat3) -> Option<[[f32; 4]; 5]> {
    let lobe = ShadeLobe::new(brdf, n, v);
    let a = lobe.rule_scale()?;
    let f = |d: DVec3, w: f64| [d.x as f32, d.y as f32, d.z as f32, w as f32];
    Some([
        f(world_to_file * lobe.frame.t, 0.0),
        f(world_to_file * lobe.frame.b, 0.0),
        f(world_to_file * lobe.frame.n, 0.0),
        f(lobe.wo, 0.0),
        f(world_to_file * lobe.axis, a),
    ])
}

/// The largest lobe scale [`ExactFilter::shade`] takes, radians: the diffuse lobe's (1) would
/// leave a texel of a 128-wide map to its centre node, whose error (ρ/w)²/24 there is 1e-4 of
/// a sun's term; at 0.25 such texels take 2 × 2 Gauss points, while a 1k map's (ρ ≈ 0.006)
/// still take one node.
const SHADE_SCALE_MAX: f64 = 0.25;

/// Rows (of all layers, in order) a unit of work sums; partial sums join in row order, so
/// the results do not depend on the number of threads.
const ROWS_PER_CHUNK: usize = 8;

/// The most cells a side [`ExactFilter::cell_offsets`] keeps tables for (the rule takes at
/// most [`MAX_CELLS_PER_WIDTH`] × the cells per scale, 64 at the tests' finest).
const MAX_TABLED_CELLS: usize = 128;

/// Where Gauss point `n` (of 2s along a side) of a texel cut into s cells a side lies, in
/// texels from the texel's start.
fn gauss_node(n: u32, s: u32) -> f64 {
    let g = 0.5 / 3f64.sqrt();
    ((n / 2) as f64 + 0.5 + if n.is_multiple_of(2) { -g } else { g }) / s as f64
}

/// The (sine, cosine) of a lat-long texel's Gauss points' offsets from its centre, in polar
/// angle (`theta`) and azimuth (`phi`), for one number of cells a side: the same for every
/// texel of the map.
struct CellOffsets {
    theta: Vec<(f64, f64)>,
    phi: Vec<(f64, f64)>,
}

/// [`Texel::reach`] for row `j` of a `w × h` lat-long map: the chord from a texel's centre to
/// its furthest corner (the angle from the centre along an edge of constant azimuth is a
/// sinusoid in θ, so no inner point lies further), with room for rounding.
fn latlong_reach(w: u32, h: u32, j: u32) -> f64 {
    use std::f64::consts::{PI, TAU};
    let dir = |theta: f64, phi: f64| {
        let (st, ct) = theta.sin_cos();
        DVec3::new(st * phi.sin(), ct, -st * phi.cos())
    };
    let (dt, dp) = (PI / h as f64, TAU / w as f64);
    let centre = dir(dt * (j as f64 + 0.5), 0.0);
    let far = [dt * j as f64, dt * (j + 1) as f64]
        .map(|theta| (dir(theta, 0.5 * dp) - centre).length())
        .into_iter()
        .fold(0.0, f64::max);
    far * (1.0 + 1e-9) + 1e-12
}

/// A map prepared for exact filters: its texels' world directions, solid angles and values,
/// found as the sums visit them.
pub struct ExactFilter<'a> {
    map: &'a EnvMap,
    file_to_world: DMat3,
    /// A lat-long map's (sin, cos) of each column's azimuth 2π·u at its centre (empty for
    /// other mappings): a texel's direction is then its row's and its column's, as
    /// [`Mapping::coord_to_dir`] finds it, without a sine per texel.
    columns: Vec<(f64, f64)>,
    /// Other mappings' texel solid angles ([`Mapping::texel_solid_angles`]; empty for a
    /// lat-long, whose rows share one).
    omega: Vec<f64>,
    /// A lat-long map's Gauss point offsets by cells a side, made on first use (empty for
    /// other mappings).
    cells: Vec<std::sync::OnceLock<CellOffsets>>,
    /// Whether lat-long texels carry their reach and angles (the tests turn it off to check
    /// those shortcuts against the general rule).
    shortcuts: bool,
}

impl<'a> ExactFilter<'a> {
    /// Prepares `map`, whose file directions reach the world through `file_to_world`.
    pub fn new(map: &'a EnvMap, file_to_world: DMat3) -> ExactFilter<'a> {
        let columns = match map.mapping {
            Mapping::LatLong => (0..map.width)
                .map(|i| {
                    let u = Mapping::texel_center(map.width, map.height, 0, i, 0).u;
                    (std::f64::consts::TAU * u).sin_cos()
                })
                .collect(),
            _ => Vec::new(),
        };
        let omega = match map.mapping {
            Mapping::LatLong => Vec::new(),
            m => m.texel_solid_angles(map.width, map.height),
        };
        let cells = match map.mapping {
            Mapping::LatLong => (0..=MAX_TABLED_CELLS).map(|_| Default::default()).collect(),
            _ => Vec::new(),
        };
        ExactFilter {
            map,
            file_to_world,
            columns,
            omega,
            cells,
            shortcuts: true,
        }
    }

    /// The texels of row `j` of `layer` that hold part of the sphere, into `out`.
    fn row(&self, layer: u32, j: u32, out: &mut Vec<Texel>) {
        out.clear();
        let map = self.map;
        let (w, h) = (map.width, map.height);
        if map.mapping == Mapping::LatLong {
            // coord_to_dir's lat-long rule, the row's polar angle and solid angle found once.
            let v = Mapping::texel_center(w, h, 0, 0, j).v;
            let (st, ct) = (std::f64::consts::PI * v).sin_cos();
            let omega = map.mapping.texel_solid_angle(w, h, 0, j);
            let reach = match self.shortcuts {
                true => latlong_reach(w, h, j),
                false => f64::INFINITY,
            };
            for (i, &(sp, cp)) in (0..w).zip(&self.columns) {
                out.push(Texel {
                    layer,
                    i,
                    j,
                    dir: self.file_to_world * DVec3::new(st * sp, ct, -st * cp),
                    omega,
                    rho: omega.sqrt(),
                    radiance: map.texel(layer, i, j).map(f64::from),
                    reach,
                    angles: self.shortcuts.then_some([st, ct, sp, cp]),
                });
            }
            return;
        }
        for i in 0..w {
            let omega = self.omega[(j * w + i) as usize];
            if omega <= 0.0 && !map.mapping.texel_in_domain(w, h, i, j) {
                continue;
            }
            let Some((si, sj)) = map.mapping.integration_source(w, h, i, j) else {
                continue;
            };
            let c = map
                .mapping
                .coord_to_dir(Mapping::texel_center(w, h, layer, i, j));
            out.push(Texel {
                layer,
                i,
                j,
                dir: self.file_to_world * c,
                omega,
                rho: omega.sqrt(),
                radiance: map.texel(layer, si, sj).map(f64::from),
                reach: f64::INFINITY,
                angles: None,
            });
        }
    }

    /// `f(chunk's texels, state)` over the map's rows in chunks of [`ROWS_PER_CHUNK`] on
    /// every core, each chunk from a fresh `init()`; the chunks' states in row order.
    fn chunks<S: Send>(
        &self,
        init: impl Fn() -> S + Sync,
        f: impl Fn(&[Texel], &mut S) + Sync,
    ) -> Vec<S> {
        let map = self.map;
        let rows = (map.layers() * map.height) as usize;
        let count = rows.div_ceil(ROWS_PER_CHUNK);
        let next = std::sync::atomic::AtomicUsize::new(0);
        let threads = std::thread::available_parallelism()
            .map_or(1, |n| n.get())
            .min(count.max(1));
        let mut done: Vec<(usize, S)> = std::thread::scope(|scope| {
            let handles: Vec<_> = (0..threads)
                .map(|_| {
                    scope.spawn(|| {
                        let mut mine = Vec::new();
                        let mut texels = Vec::new();
                        loop {
                            let c = next.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
                            if c >= count {
                                return mine;
                            }
                            let mut state = init();
                            for r in c * ROWS_PER_CHUNK..((c + 1) * ROWS_PER_CHUNK).min(rows) {
                                let (layer, j) = (
                                    (r / map.height as usize) as u32,
                                    (r % map.height as usize) as u32,
                                );
                                self.row(layer, j, &mut texels);
                                f(&texels, &mut state);
                            }
                            mine.push((c, state));
                        }
                    })
                })
                .collect();
            handles
                .into_iter()
                .flat_map(|h| h.join().unwrap_or_else(|e| std::panic::resume_unwind(e)))
                .collect()
        });
        done.sort_by_key(|(c, _)| *c);
        done.into_iter().map(|(_, s)| s).collect()
    }

    /// The world direction of the brightest texel (by luminance; the last in row order of
    /// equals).
    pub fn brightest(&self) -> DVec3 {
        let lum = crate::math::envmap::luminance;
        self.chunks(
            || (f64::NEG_INFINITY, DVec3::Z),
            |texels, best| {
                for t in texels {
                    let y = lum(t.radiance);
                    if y >= best.0 {
                        *best = (y, t.dir);
                    }
                }
            },
        )
        .into_iter()
        .fold(
            (f64::NEG_INFINITY, DVec3::Z),
            |a, b| if b.0 > a.0 { b } else { a },
        )
        .1
    }

    /// Every query's value ([`ExactFilter::ggx`], [`ExactFilter::irradiance`]) in one pass
    /// over the map, in the queries' order.
    pub fn evaluate(&self, queries: &[Query]) -> Vec<[f64; 3]> {
        self.evaluate_with(queries, PER_WIDTH)
    }

    /// [`ExactFilter::evaluate`] with `per_width` cells per lobe scale ([`PER_WIDTH`] there):
    /// twice as many estimate the rule's own error by its change.
    pub fn evaluate_with(&self, queries: &[Query], per_width: f64) -> Vec<[f64; 3]> {
        let prepared: Vec<Prepared> = queries
            .iter()
            .map(|q| match *q {
                Query::Ggx { r, alpha } => {
                    let a = alpha.max(super::brdf::GGX_ALPHA_MIN);
                    Prepared::Ggx {
                        r,
                        // Sub-cell directions are found in the file frame.
                        r_file: self.file_to_world.transpose() * r,
                        a,
                    }
                }
                Query::Irradiance { n } => Prepared::Irradiance { n },
                Query::Shade { brdf, n, v } => Prepared::Shade(self.shade_lobe(brdf, n, v)),
            })
            .collect();
        // Per query: Σ K·L per channel and Σ K, over a chunk's texels query by query.
        let n = queries.len();
        let add = |s: &mut [f64; 4], k: f64, t: &Texel| {
            for (s, l) in s.iter_mut().zip(t.radiance) {
                *s += k * l;
            }
            s[3] += k;
        };
        let parts = self.chunks(
            || vec![[0.0f64; 4]; n],
            |texels, sums| {
                for (q, s) in prepared.iter().zip(sums.iter_mut()) {
                    match *q {
                        Prepared::Ggx { r, r_file, a } => {
                            for t in texels {
                                add(s, self.ggx_weight(t, r, r_file, a, per_width), t);
                            }
                        }
                        Prepared::Irradiance { n } => {
                            for t in texels {
                                add(s, n.dot(t.dir).max(0.0) * t.omega, t);
                            }
                        }
                        Prepared::Shade(ref lobe) => {
                            for t in texels {
                                add(s, self.shade_weight(t, lobe, per_width), t);
                            }
                        }
                    }
                }
            },
        );
        let mut total = vec![[0.0f64; 4]; n];
        for p in parts {
            for (t, s) in total.iter_mut().zip(p) {
                for (a, b) in t.iter_mut().zip(s) {
                    *a += b;
                }
            }
        }
        queries
            .iter()
            .zip(total)
            .map(|(q, t)| match q {
                Query::Ggx { .. } if t[3] > 0.0 => [t[0] / t[3], t[1] / t[3], t[2] / t[3]],
                Query::Ggx { .. } => [0.0; 3],
                Query::Irradiance { .. } | Query::Shade { .. } => [t[0], t[1], t[2]],
            })
            .collect()
    }

    /// P(r, α) = ∫ L·K / ∫ K, K = [`chain_kernel`], `r` a world direction: what level α of
    /// split-sum's chain (and of the bake's specular cube) stands for.
    ///
    /// A texel is split into s × s cells of 2 × 2 Gauss points, s = ⌈4ρ/w⌉ ≤ 32 for ρ its
    /// angular size and w the lobe's scale there (α at the peak, θ/8 in the tail at angle θ
    /// from r, where K ∝ θ⁻⁴; the chord stands for θ), each point weighted by the mapping's
    /// density and the texel's weights scaled to its exact solid angle; where 4ρ/w < 0.2 it
    /// takes one node at its centre. The tests bound this sum's own error.
    pub fn ggx(&self, r: DVec3, alpha: f64) -> [f64; 3] {
        self.ggx_with(r, alpha, 4.0)
    }

    /// [`ExactFilter::ggx`] with `per_width` cells per lobe scale (the tests refine it).
    fn ggx_with(&self, r: DVec3, alpha: f64, per_width: f64) -> [f64; 3] {
        self.evaluate_with(&[Query::Ggx { r, alpha }], per_width)[0]
    }

    /// Texel `t`'s weight ∫_t K dω in [`ExactFilter::ggx_with`]'s sum for the lobe about `r`
    /// (world; `r_file` in the file frame) at α = `a`.
    fn ggx_weight(&self, t: &Texel, r: DVec3, r_file: DVec3, a: f64, per_width: f64) -> f64 {
        let chord2 = (t.dir - r).length_squared();
        let gap = 0.5 * chord2;
        // The lobe's scale there, w = max(α, chord/8): the chord, below the angle θ, stands
        // for it (more cells, never fewer). One node at the centre where 4ρ < 0.2·w, the
        // texel small next to the scale (its error is about (ρ/w)²/24 of the texel's term),
        // compared in squares so that most texels take no root; Gauss cells elsewhere, whose
        // error falls as the fourth power of the cell's size against the lobe's.
        let w2 = (a * a).max(TAIL_FRACTION * TAIL_FRACTION * chord2);
        let size = per_width * t.rho;
        if size * size < CENTRE_BELOW * CENTRE_BELOW * w2 {
            return chain_kernel(a, gap) * t.omega;
        }
        let s = (size / w2.sqrt()).ceil().min(8.0 * per_width) as u32;
        let mean = self.cell_mean(t, s, |d| {
            chain_kernel(a, 0.5 * (d - r_file).length_squared())
        });
        mean.map_or(chain_kernel(a, gap) * t.omega, |m| m * t.omega)
    }

    /// The radiance `brdf` (F = 1) reflects towards `v` at a surface of normal `n` (world,
    /// unit) under the map, unshadowed: ∫ L(ω)·f(v, ω)·(n·ω)₊ dω, summed over every texel
    /// with nothing sampled, so it has no noise: the reference a sphere's pixel is scored
    /// against. Each texel's ∫ f·cos over its solid angle follows [`ExactFilter::ggx`]'s
    /// rule about the lobe's axis (the reflected direction; the normal for the diffuse lobe)
    /// at the lobe's scale ([`lobe_scale`]): one node at the centre where the texel is small
    /// next to the scale, s × s cells of 2 × 2 Gauss points elsewhere. A view below the
    /// horizon is lifted as FIS lifts it; a mirror reflects the texel its reflected direction
    /// falls in (the map's constant radiance over a texel, exactly).
    pub fn shade(&self, brdf: &Brdf, n: DVec3, v: DVec3) -> [f64; 3] {
        self.shade_with(brdf, n, v, PER_WIDTH)
    }

    /// [`ExactFilter::shade`] with `per_width` cells per lobe scale (the tests refine it).
    fn shade_with(&self, brdf: &Brdf, n: DVec3, v: DVec3, per_width: f64) -> [f64; 3] {
        let q = Query::Shade { brdf: *brdf, n, v };
        self.evaluate_with(&[q], per_width)[0]
    }

    /// A shade query's lobe, with the texel its reflected direction falls in.
    fn shade_lobe(&self, brdf: Brdf, n: DVec3, v: DVec3) -> ShadeLobe {
        let lobe = ShadeLobe::new(brdf, n, v);
        let axis_file = self.file_to_world.transpose() * lobe.axis;
        let (w, h) = (self.map.width, self.map.height);
        let c = self.map.mapping.dir_to_coord(axis_file);
        let at = |x: f64, n: u32| ((x * n as f64).floor().max(0.0) as u32).min(n - 1);
        ShadeLobe {
            reflected: (c.layer, at(c.u, w), at(c.v, h)),
            ..lobe
        }
    }

    /// Texel `t`'s ∫_t f·cos dω for `lobe` ([`ExactFilter::shade`]).
    fn shade_weight(&self, t: &Texel, lobe: &ShadeLobe, per_width: f64) -> f64 {
        let Some(a) = lobe.rule_scale() else {
            // The mirror: the whole lobe where the texel holds the reflected direction.
            return f64::from(u8::from((t.layer, t.i, t.j) == lobe.reflected));
        };
        let f = |d: DVec3| lobe.brdf.eval_cos(lobe.wo, lobe.frame.to_local(d));
        // The lobe's scale, at most SHADE_SCALE_MAX, about its axis and in its tail as
        // ExactFilter::ggx's; and near the horizon, where Smith's masking takes f·cos to 0
        // over an angle of about α (and the cosine kinks), at most the horizon's sine
        // (HORIZON_REACH × the tail's fraction of it): the cosine is that sine, linear, and
        // the masking varies over about α.
        let horizon = lobe.frame.n.dot(t.dir);
        if horizon < -t.reach {
            // Wholly below the surface: f·cos is 0 at every point.
            return 0.0;
        }
        let chord2 = (t.dir - lobe.axis).length_squared();
        let reach2 = HORIZON_REACH * HORIZON_REACH * horizon * horizon;
        let tail2 = TAIL_FRACTION * TAIL_FRACTION * chord2.min(reach2);
        let mut w2 = (a * a).max(tail2);
        if horizon.abs() < t.rho {
            // The horizon crosses the texel: f·cos kinks there, which Gauss points
            // integrate to the square of their cells only; a quarter of the scale.
            w2 /= HORIZON_SHRINK * HORIZON_SHRINK;
        }
        let size = per_width * t.rho;
        if size * size < CENTRE_BELOW * CENTRE_BELOW * w2 {
            return f(t.dir) * t.omega;
        }
        let s = (size / w2.sqrt())
            .ceil()
            .min(MAX_CELLS_PER_WIDTH * per_width) as u32;
        let mean = self.cell_mean(t, s, |d_file| f(self.file_to_world * d_file));
        mean.map_or(f(t.dir) * t.omega, |m| m * t.omega)
    }

    /// The mean of `k` (a function of file-frame directions) over texel `t` by s × s cells
    /// of 2 × 2 Gauss points weighted by the mapping's density; `None` where no node holds
    /// part of the sphere. A lat-long texel's points are found from its centre's angles by
    /// angle addition ([`CellOffsets`]): no sine per point.
    fn cell_mean(&self, t: &Texel, s: u32, k: impl Fn(DVec3) -> f64) -> Option<f64> {
        if let (Some([st, ct, sp, cp]), Some(cells)) = (t.angles, self.cell_offsets(s)) {
            let (mut kw, mut ww) = (0.0, 0.0);
            for &(sd, cd) in &cells.theta {
                // sin θ ≥ 0 inside the map; the density 2π² sin θ up to its constant.
                let (stb, ctb) = (st * cd + ct * sd, ct * cd - st * sd);
                for &(sq, cq) in &cells.phi {
                    let (spq, cpq) = (sp * cq + cp * sq, cp * cq - sp * sq);
                    kw += stb * k(DVec3::new(stb * spq, ctb, -stb * cpq));
                    ww += stb;
                }
            }
            return (ww > 0.0).then(|| kw / ww);
        }
        let map = self.map;
        let (w, h) = (map.width, map.height);
        let (mut kw, mut ww) = (0.0, 0.0);
        for b in 0..2 * s {
            for q in 0..2 * s {
                let cc = Coord {
                    layer: t.layer,
                    u: (t.i as f64 + gauss_node(q, s)) / w as f64,
                    v: (t.j as f64 + gauss_node(b, s)) / h as f64,
                };
                let wt = map.mapping.footprint_weight(cc);
                kw += wt * k(map.mapping.coord_to_dir(cc));
                ww += wt;
            }
        }
        (ww > 0.0).then(|| kw / ww)
    }

    /// A lat-long map's [`CellOffsets`] for `s` × `s` cells a texel, made on first use;
    /// `None` for other mappings and for `s` above [`MAX_TABLED_CELLS`].
    fn cell_offsets(&self, s: u32) -> Option<&CellOffsets> {
        let slot = self.cells.get(s as usize)?;
        let (w, h) = (self.map.width as f64, self.map.height as f64);
        Some(slot.get_or_init(|| {
            let side = |span: f64, n: f64| {
                (0..2 * s)
                    .map(|q| (span * (gauss_node(q, s) - 0.5) / n).sin_cos())
                    .collect()
            };
            CellOffsets {
                theta: side(std::f64::consts::PI, h),
                phi: side(std::f64::consts::TAU, w),
            }
        }))
    }

    /// Irradiance E(n) = ∫ L·max(0, n·ω) dω, one node per texel: the cosine's scale is a
    /// radian, so a texel of angular size ρ errs by about ρ²/24 of its term (4·10⁻⁷ at 1k).
    pub fn irradiance(&self, n: DVec3) -> [f64; 3] {
        self.evaluate(&[Query::Irradiance { n }])[0]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The views the shade tests take: (n·v, azimuth of v about n), head-on to grazing.
    fn views() -> Vec<(DVec3, DVec3)> {
        let n = DVec3::new(0.2, 0.9, -0.3).normalize();
        let frame = Frame::new(n);
        [1.0, 0.7, 0.3, 0.05]
            .iter()
            .zip([0.0, 1.1, 2.5, 4.0])
            .map(|(mu, phi): (&f64, f64)| {
                let s = (1.0 - mu * mu).sqrt();
                (
                    n,
                    frame.to_world(DVec3::new(s * phi.cos(), s * phi.sin(), *mu)),
                )
            })
            .collect()
    }

    /// The BRDFs the shade tests take: diffuse, Phong 64, GGX from sharp to rough.
    fn brdfs() -> Vec<Brdf> {
        let mut v = vec![Brdf::Lambert, Brdf::Phong { n: 64.0 }];
        v.extend([0.05, 0.1, 0.3, 0.6].map(|a| super::super::split_sum::ggx(a, true)));
        v
    }

    /// ∫ f(wo, ω)·cos·g(ω) dω by importance-sampled Monte Carlo over 2²⁰ Hammersley
    /// points (`Brdf::sample`), `g` a function of the local direction: the shade tests'
    /// independent oracle (within 1e-8 of the refined texel sums under a constant sky at
    /// α 0.05–0.1, head-on and at n·v = 0.05, where the albedo quadratures `Brdf::albedo`
    /// and `albedo_rule` err by 1e-4–2e-4).
    fn sampled(brdf: &Brdf, wo: DVec3, g: impl Fn(DVec3) -> f64) -> f64 {
        let count = 1u32 << 20;
        let mut sum = 0.0;
        for i in 0..count {
            let wi = brdf.sample(wo, crate::math::sequence::hammersley(i, count));
            let pdf = brdf.pdf(wo, wi);
            if pdf > 0.0 && wi.z > 0.0 {
                sum += brdf.eval_cos(wo, wi) / pdf * g(wi);
            }
        }
        sum / count as f64
    }

    /// The white furnace: under a constant environment L the shade is L times the BRDF's
    /// directional albedo, sampled ([`sampled`]), at every view down to n·v = 0.05, on a
    /// lat-long 256 × 128 and a cube 64 a side (texels of 0.025 rad, half the sharpest
    /// lobe): within 5e-5, the rule's own error (Phong 64's texels, a fifth of its width,
    /// take 2 × 2 Gauss points: 3e-5 head-on).
    #[test]
    fn shade_under_a_constant_sky_is_the_albedo() {
        let l = [1.0, 0.5, 2.0];
        let maps = [
            EnvMap::from_fn(Mapping::LatLong, 256, 128, 1, |_| l),
            EnvMap::from_fn(Mapping::Cube, 64, 64, 1, |_| l),
        ];
        for brdf in brdfs() {
            for (n, v) in views() {
                let wo = local_view(&Frame::new(n), v);
                let want = sampled(&brdf, wo, |_| 1.0);
                for env in &maps {
                    let f = ExactFilter::new(env, DMat3::from_rotation_y(0.4));
                    let got = f.shade(&brdf, n, v);
                    for c in 0..3 {
                        let err = (got[c] / l[c] - want).abs();
                        assert!(
                            err < 5e-5 * want.max(0.05),
                            "{:?} {brdf:?} n·v {:.2}: {} vs {want}",
                            env.mapping,
                            wo.z,
                            got[c] / l[c]
                        );
                    }
                }
            }
        }
    }

    /// On L(ω) = a + b·ω (256 × 128, where texel centres stand for texel means to 1e-4) the
    /// shade is what [`sampled`] finds over the same analytic L, within 2e-4 (the centres'
    /// error). The diffuse lobe is the irradiance over π (whose one node a texel errs by
    /// ρ²/24, 3e-5 here); a mirror reads its texel.
    #[test]
    fn shade_of_a_linear_map_meets_sampling() {
        let b = DVec3::new(0.3, -0.5, 0.4);
        let lin = |d: DVec3| 1.0 + b.dot(d);
        let env = EnvMap::from_fn(Mapping::LatLong, 256, 128, 1, |d| [lin(d); 3]);
        let f = ExactFilter::new(&env, DMat3::IDENTITY);
        for brdf in brdfs() {
            for (n, v) in views() {
                let frame = Frame::new(n);
                let wo = local_view(&frame, v);
                let mc = sampled(&brdf, wo, |wi| lin(frame.to_world(wi)));
                let got = f.shade(&brdf, n, v)[0];
                assert!(
                    (got - mc).abs() < 2e-4 * mc.abs().max(0.05),
                    "{brdf:?} n·v {:.2}: exact {got} sampled {mc}",
                    wo.z
                );
            }
        }
        for (n, v) in views() {
            let e = f.irradiance(n)[0] / std::f64::consts::PI;
            let got = f.shade(&Brdf::Lambert, n, v)[0];
            assert!((got - e).abs() < 1e-4 * e, "{got} vs {e}");
            let r = 2.0 * n.dot(v) * n - v;
            let mirror = f.shade(&Brdf::Mirror, n, v)[0];
            assert_eq!(mirror, crate::math::convert::sample_nearest(&env, r)[0]);
        }
    }

    /// A sun 10⁵ × the sky a few texels wide, in the lobe, at its edge and in its tail:
    /// doubling the cells per lobe scale moves the shade by < 1e-4, at a grazing view too.
    #[test]
    fn shade_converges_in_its_cells() {
        let (env, turn, sun) = turned_sun_sky();
        let f = ExactFilter::new(&env, turn);
        let n = (sun + DVec3::Y).normalize();
        let frame = Frame::new(n);
        for brdf in brdfs() {
            for mu in [0.9, 0.2] {
                // v with the sun in its reflection, then a little off it.
                let toward = frame.to_local(sun);
                let v0 = frame.to_world(DVec3::new(-toward.x, -toward.y, toward.z));
                for v in [v0, (v0 + DVec3::new(0.0, 0.0, 0.05)).normalize()] {
                    let v = (v + n * (mu - v.dot(n))).normalize();
                    let a = f.shade(&brdf, n, v)[0];
                    let b = f.shade_with(&brdf, n, v, 8.0)[0];
                    assert!(
                        (a - b).abs() < 1e-4 * b.abs(),
                        "{brdf:?} n·v {mu}: {a} vs {b} refined"
                    );
                }
            }
        }
    }

    /// On L(ω) = a + b·ω the filter is a + (b·r)·x̄, x̄ the kernel's mean cosine, which a 1D
    /// rule over x gives independently (the kernel is zonal: dω = 2π dx). The map stores
    /// texel-centre values, which differ from texel means by O(ρ²) ≈ 1e-4 at 256 × 128.
    /// The irradiance of the same map is π·a + (2π/3)·b·n.
    #[test]
    fn exact_filters_of_a_linear_map() {
        let b = DVec3::new(0.3, -0.5, 0.8);
        let env = EnvMap::from_fn(Mapping::LatLong, 256, 128, 1, |d| {
            let v = 1.0 + b.dot(d);
            [v, 2.0 * v, 0.5]
        });
        let f = ExactFilter::new(&env, DMat3::IDENTITY);
        for alpha in [0.05, 0.3, 1.0] {
            let (mut k0, mut k1) = (0.0, 0.0);
            let n = 200_000;
            for q in 0..n {
                // Midpoints in t = √(1 − x), which grades the nodes towards the peak x = 1.
                let t = (q as f64 + 0.5) / n as f64;
                let k = chain_kernel(alpha, t * t) * 2.0 * t;
                k0 += k;
                k1 += k * (1.0 - t * t);
            }
            let mean = k1 / k0;
            for r in [DVec3::Z, DVec3::new(0.6, 0.0, 0.8), -DVec3::Y] {
                let got = f.ggx(r, alpha);
                let want = 1.0 + b.dot(r) * mean;
                assert!(
                    (got[0] - want).abs() < 2e-4,
                    "α {alpha} r {r}: {got:?} vs {want}"
                );
                assert!((got[1] - 2.0 * want).abs() < 4e-4);
                assert!((got[2] - 0.5).abs() < 1e-12);
            }
        }
        let pi = std::f64::consts::PI;
        for n in [DVec3::Z, DVec3::new(0.0, 0.6, -0.8)] {
            let e = f.irradiance(n);
            let want = pi + 2.0 * pi / 3.0 * b.dot(n);
            assert!((e[0] - want).abs() < 1e-3 * want, "{e:?} vs {want}");
        }
    }

    /// A 128 × 64 sky with a sun 10⁵ × it a few texels wide, its file turned about z: the
    /// map, its file-to-world turn and the sun's world direction.
    fn turned_sun_sky() -> (EnvMap, DMat3, DVec3) {
        let turn = DMat3::from_rotation_z(0.7);
        let sun_file = DVec3::new(0.3, 0.5, 0.8).normalize();
        let env = EnvMap::from_fn(Mapping::LatLong, 128, 64, 1, |d| {
            let v = if d.dot(sun_file) > 0.9995 {
                1e5
            } else {
                1.0 + d.y.max(0.0)
            };
            [v; 3]
        });
        (env, turn, turn * sun_file)
    }

    /// A sun 10⁵ × the sky, a few texels wide, under a lobe narrower than a texel, one a few
    /// texels wide, and one whose tail alone sees it: doubling the cells per lobe scale moves
    /// the result by < 1e-4. The map is turned, so sub-cells are found in the file frame.
    #[test]
    fn exact_ggx_converges_in_its_cells() {
        let (env, turn, sun) = turned_sun_sky();
        let f = ExactFilter::new(&env, turn);
        assert!(f.brightest().dot(sun) > 0.999);
        for alpha in [0.005, 0.02, 0.1] {
            for r in [
                sun,
                (sun + DVec3::new(0.0, 0.04, 0.0)).normalize(),
                DVec3::X,
            ] {
                let a = f.ggx(r, alpha)[0];
                let b = f.ggx_with(r, alpha, 8.0)[0];
                assert!((a - b).abs() <= 1e-4 * b, "α {alpha} r {r}: {a} vs {b}");
            }
        }
    }

    /// A lat-long map's shortcuts (texels wholly below the horizon skipped, Gauss points by
    /// angle addition) change no sum beyond rounding: every BRDF, views from head-on to
    /// grazing, the sun in the lobe, in its tail and just below the horizon, within 1e-12
    /// of the general rule's sums.
    #[test]
    fn lat_long_shortcuts_keep_the_sums() {
        let (env, turn, sun) = turned_sun_sky();
        let fast = ExactFilter::new(&env, turn);
        let general = ExactFilter {
            shortcuts: false,
            cells: Vec::new(),
            ..ExactFilter::new(&env, turn)
        };
        let mut brdfs = brdfs();
        brdfs.push(Brdf::Ward { ax: 0.1, ay: 0.4 });
        // Normals: the sun's mirror direction about a view, the sun 0.02 rad below the
        // horizon (its texels straddle it), and one far from it.
        let tilt = DVec3::new(0.0, 0.0, 1.0).cross(sun).normalize();
        let below = DMat3::from_axis_angle(tilt, std::f64::consts::FRAC_PI_2 + 0.02) * sun;
        for n in [
            sun,
            below.normalize(),
            DVec3::new(-0.5, 0.2, 0.3).normalize(),
        ] {
            for brdf in &brdfs {
                for (_, v) in views() {
                    // views() turns about its own normal; carry it to n.
                    let frame = Frame::new(n);
                    let local = Frame::new(DVec3::new(0.2, 0.9, -0.3).normalize()).to_local(v);
                    let v = frame.to_world(local);
                    let (a, b) = (fast.shade(brdf, n, v), general.shade(brdf, n, v));
                    for c in 0..3 {
                        assert!(
                            (a[c] - b[c]).abs() <= 1e-12 * b[c].abs().max(1e-300),
                            "{brdf:?} n {n} v {v}: {} vs {}",
                            a[c],
                            b[c]
                        );
                    }
                }
            }
        }
    }
}
