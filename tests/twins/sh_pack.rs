//! The SH packing pass against its float64 twin (`math::sh::pack`).
//! `tests/sh_pack.rs` runs it; `tests/mutation.rs` runs it on the pass's poisoned outputs.
#![allow(dead_code, unused_imports)]

use crate::common::compare::{max_abs, Errors};
use envlight::gpu::{Context, Timed};
use envlight::math::sh;
use envlight::math::synth::{smooth_env, Sky};
use envlight::math::Mapping;
use envlight::passes::sh_pack::{irradiance_entries, windowed_entries, ShPacker, Window};
use envlight::EnvMap;

/// The bound [`check`] holds each packed coefficient to, relative to the set's largest.
pub const BOUND: f64 = 1e-6;

/// Three sets as a render packs them, from one projection to l = 8 of the sun sky: SH l = 2
/// irradiance of the map less a second set (a smooth map's coefficients, standing for the light
/// texels'), SH l = 8 irradiance of the whole map, and the radiance to l = 8 under a Hanning
/// window of width 6. The GPU reads f32 copies of both sets and multiplies once: within
/// 1e-6 of the largest packed value (f32 rounding, ~1e-7, of inputs that cancel by at most
/// a factor of a few).
pub fn check(ctx: &Context) {
    let sky = Sky::default();
    let map = EnvMap::from_fn(Mapping::LatLong, 64, 32, 2, |d| sky.radiance(d));
    let radiance = sh::project(&map, 8);
    let other = EnvMap::from_fn(Mapping::LatLong, 64, 32, 2, smooth_env);
    let minus = sh::project(&other, 8);
    let mut entries = irradiance_entries(2, true);
    entries.extend(irradiance_entries(8, false));
    entries.extend(windowed_entries(8, Window::Hanning { width: 6.0 }));
    let packer = ShPacker::new(ctx).unwrap();
    let Timed {
        value: got,
        timings: t,
    } = packer.run(&radiance, &minus, &entries).unwrap();
    assert!(t.iter().any(|t| t.label == "sh pack"));
    let want = sh::pack(&radiance, &minus, &entries);
    assert_eq!(got.len(), want.len());
    let top = max_abs(want.iter().flatten().copied());
    let mut errors = Errors::new();
    for (k, (g, w)) in got.iter().zip(&want).enumerate() {
        for c in 0..3 {
            errors.abs(g[c], w[c], (k, c));
        }
    }
    let worst = errors.worst() / top;
    eprintln!(
        "sh pack: {} coefficients, worst {worst:.2e} of the largest",
        got.len()
    );
    assert!(worst < BOUND, "{worst:e} at {:?}", errors.at());
}
