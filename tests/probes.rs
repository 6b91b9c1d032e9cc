//! Every real probe in ENVLIGHT_PROBES: loads with sane statistics, keeps its power through
//! conversion, and Grace Cathedral's two files agree after the documented flips.

mod common;

use common::compare::finite;
use envlight::gpu::Timed;
use envlight::io::{self, LoadOptions};
use envlight::math::Mapping;
use envlight::passes::{ConvertOptions, Converter};
use envlight::GpuEnvMap;
use envlight::{EnvMap, Orientation};
use std::path::{Path, PathBuf};

/// Every probe file (the six pisaHDR faces as one `{face}` pattern) with its expected mapping.
fn all_probes(dir: &Path) -> Vec<(String, Mapping)> {
    let mut v = Vec::new();
    let mut entries: Vec<PathBuf> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    entries.sort();
    for p in entries {
        let name = p.file_name().unwrap().to_string_lossy().to_string();
        if p.is_dir() {
            if p.join("px.hdr").exists() {
                v.push((
                    p.join("{face}.hdr").to_string_lossy().to_string(),
                    Mapping::Cube,
                ));
            }
            continue;
        }
        let m = if name.ends_with(".dds") {
            Mapping::Cube
        } else if name.contains("_probe") {
            Mapping::Angular
        } else if name.ends_with(".hdr") || name.ends_with(".exr") {
            Mapping::LatLong
        } else {
            continue;
        };
        v.push((p.to_string_lossy().to_string(), m));
    }
    v
}

fn load(spec: &str) -> EnvMap {
    let opts = LoadOptions::default();
    let r = match io::face_paths(spec) {
        Some(paths) => io::load_cube_faces(&paths, &opts),
        None => io::load(spec, &opts),
    };
    r.unwrap_or_else(|e| panic!("{spec}: {e}"))
}

#[test]
fn every_real_probe_loads_with_sane_statistics() {
    let Some(dir) = common::probes() else { return };
    let probes = all_probes(&dir);
    assert!(
        probes.len() >= 20,
        "only {} probes found in {}",
        probes.len(),
        dir.display()
    );
    for (spec, mapping) in probes {
        let map = load(&spec);
        assert_eq!(map.mapping, mapping, "{spec}: mapping inferred wrongly");
        let s = map.stats();
        eprintln!(
            "{spec}: {}x{}x{} max lum {:.3e} power {:.3e}",
            map.width,
            map.height,
            map.layers(),
            s.max_luminance,
            s.power[1]
        );
        assert_eq!(s.nan + s.inf + s.negative, 0, "{spec}: invalid texels");
        assert!(
            s.max_luminance > 1.0 && s.max_luminance < 1e6,
            "{spec}: max luminance {}",
            s.max_luminance
        );
        assert!(
            s.power.iter().all(|&p| p > 0.0 && p.is_finite()),
            "{spec}: power {:?}",
            s.power
        );
        assert!(s.min.iter().all(|&m| m >= 0.0));
    }
}

/// Power ∑ L·dω survives conversion to every other mapping within 0.5%, both at about the
/// source's resolution and heavily minified (where footprint filtering is what keeps a
/// one-texel sun's power).
#[test]
fn conversion_preserves_power_of_every_real_probe() {
    let Some(dir) = common::probes() else { return };
    let ctx = common::ctx();
    {
        let conv = Converter::new(&ctx).unwrap();
        let mut failures = Vec::new();
        for (spec, _) in all_probes(&dir) {
            let map = load(&spec);
            let pin = map.power();
            let g = GpuEnvMap::upload(&ctx, &map).unwrap();
            for to in Mapping::ALL {
                if to == map.mapping {
                    continue;
                }
                for size in [
                    match to {
                        Mapping::LatLong => 512,
                        Mapping::Cube => 128,
                        _ => 256,
                    },
                    32,
                ] {
                    let Timed { value: out, .. } =
                        conv.run(&g, &ConvertOptions::new(to, size)).unwrap();
                    let out = out.download(&ctx).unwrap();
                    let pout = out.power();
                    // The channel's signed power error of largest magnitude.
                    let mut largest = 0.0f64;
                    for k in 0..3 {
                        let e = finite(pout[k] / pin[k] - 1.0, "the power error", &(&spec, k));
                        if e.abs() > largest.abs() {
                            largest = e;
                        }
                    }
                    let worst = largest;
                    eprintln!(
                        "{spec} -> {} {size}: power {:+.3}%",
                        to.name(),
                        worst * 100.0
                    );
                    if worst.abs() >= 5e-3 {
                        failures.push(format!(
                            "{spec} -> {} {size}: {:+.3}%",
                            to.name(),
                            worst * 100.0
                        ));
                    }
                }
            }
        }
        assert!(
            failures.is_empty(),
            "power not preserved within 0.5%: {failures:#?}"
        );
    }
    common::finish(ctx);
}

fn correlation(a: &[f64], b: &[f64]) -> f64 {
    let n = a.len() as f64;
    let (ma, mb) = (a.iter().sum::<f64>() / n, b.iter().sum::<f64>() / n);
    let (mut sab, mut saa, mut sbb) = (0.0, 0.0, 0.0);
    for (x, y) in a.iter().zip(b) {
        sab += (x - ma) * (y - mb);
        saa += (x - ma) * (x - ma);
        sbb += (y - mb) * (y - mb);
    }
    sab / (saa * sbb).sqrt()
}

/// grace_probe.hdr (angular) and grace_latlong.exr (upside down and mirrored, ≈1/32 of the
/// radiance) give the same lat-long at 256×128 after --flip-u --flip-v on the latter and one
/// scale factor: Pearson correlation of luminance at least 0.98 (log luminance is reported too,
/// since linear luminance is dominated by a few windows; the unflipped file must do worse).
#[test]
fn grace_probe_and_latlong_agree_after_flips() {
    let Some(dir) = common::probes() else { return };
    let ctx = common::ctx();
    {
        let conv = Converter::new(&ctx).unwrap();
        let run = |file: &str, o: Orientation| {
            let map = load(dir.join(file).to_str().unwrap());
            let g = GpuEnvMap::upload(&ctx, &map).unwrap();
            let Timed { value: out, .. } = conv
                .run(
                    &g,
                    &ConvertOptions::new(Mapping::LatLong, 256).with_orientation(o),
                )
                .unwrap();
            out.download(&ctx).unwrap()
        };
        let probe = run("grace_probe.hdr", Orientation::default());
        let flips = Orientation {
            flip_u: true,
            flip_v: true,
            rotate_y_degrees: 0.0,
        };
        let latlong = run("grace_latlong.exr", flips);
        let unflipped = run("grace_latlong.exr", Orientation::default());
        let lum = |m: &EnvMap| -> Vec<f64> {
            m.texels
                .iter()
                .map(|t| envlight::math::envmap::luminance(t.map(f64::from)))
                .collect()
        };
        let (a, b, c) = (lum(&probe), lum(&latlong), lum(&unflipped));
        let scale = probe.power()[1] / latlong.power()[1];
        let log = |v: &[f64]| v.iter().map(|x| (x.max(1e-6)).ln()).collect::<Vec<_>>();
        let r_lin = correlation(&a, &b);
        let r_log = correlation(&log(&a), &log(&b));
        let r_wrong = correlation(&log(&a), &log(&c));
        eprintln!("grace: scale {scale:.2} correlation linear {r_lin:.4} log {r_log:.4} (unflipped log {r_wrong:.4})");
        assert!(r_lin >= 0.98, "linear correlation {r_lin} (log {r_log})");
        assert!(
            r_wrong < r_log - 0.1,
            "the flips should matter: {r_wrong} vs {r_log}"
        );
        assert!(
            (20.0..50.0).contains(&scale),
            "scale {scale}, expected about 32"
        );
    }
    common::finish(ctx);
}
