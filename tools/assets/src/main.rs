//! Writes the bundled probe, `assets/sky_latlong.exr`: the analytic sky (a gradient, a sun
//! 5·10⁴ × the zenith, a ground) as a lat-long EXR, 8 × 8 samples per texel.
//! `cargo xtask gen-assets` runs it; `envlight-assets [-o PATH] [--width N]` writes another.

use envlight::math::synth::Sky;
use envlight::{EnvMap, Mapping};
use std::path::PathBuf;
use std::process::ExitCode;

fn main() -> ExitCode {
    let (mut out, mut width) = (PathBuf::from("assets/sky_latlong.exr"), 512u32);
    let mut args = std::env::args().skip(1);
    while let Some(a) = args.next() {
        match (a.as_str(), args.next()) {
            ("-o" | "--output", Some(v)) => out = PathBuf::from(v),
            ("--width", Some(v)) => match v.parse::<u32>() {
                Ok(w) if w >= 2 => width = w,
                _ => return fail(&format!("--width {v}: give a whole number of at least 2")),
            },
            _ => return fail(&format!("unknown or incomplete argument {a}")),
        }
    }
    let map = EnvMap::from_fn(Mapping::LatLong, width, width / 2, 8, |d| {
        Sky::default().radiance(d)
    });
    if let Err(e) = envlight::io::save_exr(&map, &out) {
        return fail(&format!("{}: {e}", out.display()));
    }
    println!(
        "wrote {} ({width} x {}, max luminance {:.3e})",
        out.display(),
        width / 2,
        map.stats().max_luminance
    );
    ExitCode::SUCCESS
}

fn fail(message: &str) -> ExitCode {
    eprintln!("envlight-assets: {message}\nusage: envlight-assets [-o PATH] [--width N]");
    ExitCode::FAILURE
}
