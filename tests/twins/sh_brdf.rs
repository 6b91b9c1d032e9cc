//! The SH-BRDF table pass against the float64 projection.
//! `tests/sh_brdf.rs` runs it; `tests/mutation.rs` runs it on the pass's poisoned outputs.
#![allow(dead_code, unused_imports)]

use crate::common::compare::{abs_err, max_abs, max_of, Errors};
use crate::common::scenes::{object, scene, sphere_camera, sphere_pixels, unit_sphere};
use envlight::gpu::{total_ms, Context, Timed};
use envlight::math::brdf::{local_view, Brdf, Frame};
use envlight::math::sh::{self, count};
use envlight::math::sh_brdf::{self, ViewGrid, DEFAULT_GRID};
use envlight::math::sh_rotate::{by_quadrature, ivanic, ShRotation};
use envlight::math::synth::smooth_env;
use envlight::math::Mapping;
use envlight::passes::sh_brdf::Rotation;
use envlight::passes::{ShBrdfProjector, ShRotator};
use envlight::render::Renderer;
use envlight::scene::Technique;
use envlight::EnvMap;
use glam::{DMat3, DQuat, DVec3};

/// The bound [`check`] holds the table to, relative to its largest c₀₀ (Ward: 2e-3 at grazing views).
pub const BOUND: f64 = 1e-5;

pub fn brdfs() -> Vec<Brdf> {
    vec![
        Brdf::Lambert,
        Brdf::Phong { n: 50.0 },
        Brdf::Blinn { n: 200.0 },
        Brdf::Ggx {
            alpha: 0.3,
            correlated: true,
        },
        Brdf::Ggx {
            alpha: 0.05,
            correlated: false,
        },
        Brdf::Ggx {
            alpha: 1.0,
            correlated: false,
        },
        Brdf::Ward { ax: 0.1, ay: 0.4 },
    ]
}

/// The GPU's table (same nodes, float32) against the float64 projection, view by view, worst
/// coefficient relative to the table's largest c₀₀. Bound 1e-5: float32 sums of 4096 node
/// terms and a float32 basis give about 1e-6; sampling a narrow lobe in float32 moves its
/// directions by ~1e-7 rad. Measured worst: 2.1e-6 (printed per BRDF). Ward's weight holds
/// √(cos θᵢ/cos θₒ), and the grid's rim views sit at cos θₒ ≈ 2e-4, where float32 leaves
/// cos θᵢ of a grazing sample ~1e-3 relative error: its bound is 2e-3 (measured 5.8e-4 at the
/// rim; 1e-5 elsewhere, also asserted).
pub fn check(ctx: &Context) {
    let pass = ShBrdfProjector::new(ctx);
    let grid = ViewGrid { size: 6 };
    for b in brdfs() {
        for lmax in [2, 8] {
            let Timed {
                value: gpu,
                timings: t,
            } = pass.run(&b, lmax, grid).unwrap();
            let cpu = sh_brdf::table(&b, lmax, grid);
            let nc = count(lmax);
            let scale = max_abs(cpu.iter().step_by(nc).copied());
            let (mut all, mut inner) = (Errors::new(), Errors::new());
            for (k, (g, c)) in gpu.iter().zip(&cpu).enumerate() {
                let e = all.add(abs_err(*g, *c, k) / scale, k);
                let v = (k / nc) as u32;
                if grid.view(v % grid.size, v / grid.size).z > 0.05 {
                    inner.add(e, k);
                }
            }
            assert_eq!(all.count(), cpu.len());
            let (worst, inner) = (all.worst(), inner.worst());
            let ms: f64 = total_ms(&t);
            eprintln!(
                "{b:?} l = {lmax}: worst {worst:.1e} (views above 3°: {inner:.1e}), {ms:.1} ms for 36 views"
            );
            let bound = if matches!(b, Brdf::Ward { .. }) {
                2e-3
            } else {
                BOUND
            };
            assert!(worst < bound, "{b:?} l = {lmax}: {worst:e}");
            assert!(inner < BOUND, "{b:?} l = {lmax}: {inner:e}");
        }
    }
}
