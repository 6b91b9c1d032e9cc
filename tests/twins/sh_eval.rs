//! The SH evaluation pass against the float64 evaluation.
//! `tests/sh_eval.rs` runs it; `tests/mutation.rs` runs it on the pass's poisoned outputs.
#![allow(dead_code, unused_imports)]

use crate::common::compare::{abs_err, max_of};
use envlight::gpu::{Context, Timed};
use envlight::math::filter::{self, at_centres, Kernel};
use envlight::math::sh::{self, Window};
use envlight::math::synth::{fibonacci_sphere, smooth_env, Sky};
use envlight::math::Mapping;
use envlight::passes::sh_project::{ShProjector, Subgroups};
use envlight::passes::{FilterTarget, ShEvaluator};
use envlight::EnvMap;
use envlight::GpuEnvMap;
use glam::{DMat3, DVec3};
use std::f64::consts::PI;

/// The bound [`check`] holds each texel to, relative to |E₀₀|.
pub const BOUND: f64 = 2e-6;

/// The SH evaluation pass against the float64 evaluation of the same coefficients, windowed
/// and not, in every output mapping: f32 basis and coefficients, ~1e-6 relative of |E|.
pub fn check(ctx: &Context) {
    let eval = ShEvaluator::new(ctx).unwrap();
    let sky = Sky::default();
    let map = EnvMap::from_fn(Mapping::LatLong, 128, 64, 4, |d| sky.radiance(d));
    let radiance = sh::project(&map, 8);
    for window in [
        Window::None,
        Window::Hanning { width: 3.0 },
        Window::Sloan { lambda: 0.01 },
    ] {
        for lmax in [2u32, 8] {
            let irr = sh::irradiance_coeffs(&window.apply(&radiance[..sh::count(lmax)]));
            let scale = irr[0][2].abs();
            for to in Mapping::ALL {
                let target = FilterTarget { to, size: 8 };
                let Timed { value: out, .. } = eval.run(&irr, target).unwrap();
                let out = out.download(ctx).unwrap();
                let (w, h) = target.extent();
                let cpu = at_centres(to, w, h, |d| sh::eval(&irr, d).map(|v| v.max(0.0)));
                let mut errors = crate::common::compare::Errors::new();
                for (k, (g, c)) in out.texels.iter().zip(&cpu).enumerate() {
                    for ch in 0..3 {
                        errors.abs(g[ch], c[ch], (k, ch));
                    }
                }
                assert_eq!(errors.count(), 3 * cpu.len());
                let worst = errors.worst() / scale;
                assert!(
                    worst < BOUND,
                    "{window:?} L={lmax} {to:?}: {worst:e} of |E00| at {:?}",
                    errors.at()
                );
            }
        }
    }
}
