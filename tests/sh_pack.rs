//! The SH packing pass (`passes::sh_pack`): the shade pass's coefficient sets built on the GPU
//! from the projection's output, against the float64 twin.

mod common;
#[path = "twins/sh_pack.rs"]
mod twin;

use envlight::math::sh;
use envlight::passes::sh_pack::{irradiance_entries, windowed_entries, Window};

/// Three sets from one projection (see the twin): within 1e-6 of the largest packed value.
#[test]
fn packed_sets_match_the_float64_twin() {
    let ctx = common::ctx();
    twin::check(&ctx);
    common::finish(ctx);
}

/// The entries say what the float64 helpers do: an irradiance set is `irradiance_coeffs`, of
/// the radiance less the second set where asked; a windowed set is `Window::apply`.
#[test]
fn entries_are_the_helpers_sums() {
    let radiance: Vec<[f64; 3]> = (0..81).map(|k| [k as f64, 1.0 - k as f64, 0.5]).collect();
    let minus: Vec<[f64; 3]> = (0..81).map(|k| [0.25 * k as f64, 2.0, -1.0]).collect();
    let residual: Vec<[f64; 3]> = radiance
        .iter()
        .zip(&minus)
        .map(|(a, b)| [0, 1, 2].map(|c| a[c] - b[c]))
        .collect();
    assert_eq!(
        sh::pack(&radiance, &minus, &irradiance_entries(4, true)),
        sh::irradiance_coeffs(&residual[..25])
    );
    assert_eq!(
        sh::pack(&radiance, &minus, &irradiance_entries(8, false)),
        sh::irradiance_coeffs(&radiance)
    );
    let w = Window::Hanning { width: 5.0 };
    assert_eq!(
        sh::pack(&radiance, &minus, &windowed_entries(6, w)),
        w.apply(&radiance[..49])
    );
}
