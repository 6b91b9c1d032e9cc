//! The map commands end to end: `envlight irradiance` and `prefilter`, and the JSON
//! `envlight sh` writes.

mod common;

use common::worst_vs_cpu;

use envlight::math::sh::{self};
use envlight::math::synth::smooth_env;
use envlight::math::Mapping;
use envlight::EnvMap;

/// `envlight irradiance` (both methods) and `prefilter` run end to end: on a
/// smooth map the order-8 SH irradiance map equals the brute-force one within 1e-3 relative
/// (the smooth map's band-limit error, measured 2.5e-3 at order 2 above), the Phong prefilter
/// of n = 10 is positive and finite, and a bad window is a clear error.
#[test]
fn irradiance_and_prefilter_commands() {
    let exe = env!("CARGO_BIN_EXE_envlight");
    let dir = std::path::PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("filter_cli");
    std::fs::create_dir_all(&dir).unwrap();
    let input = dir.join("smooth.exr");
    let map = EnvMap::from_fn(Mapping::LatLong, 48, 24, 2, smooth_env);
    envlight::io::save_exr(&map, &input).unwrap();
    let run = |args: &[&str]| {
        std::process::Command::new(exe)
            .arg("--validation")
            .args(args)
            .output()
            .unwrap()
    };
    let path = |n: &str| dir.join(n).to_str().unwrap().to_string();
    let inp = input.to_str().unwrap();
    let common = ["--to", "cube", "--size", "4"];
    let o = run(&[
        &["irradiance", inp, "--method", "brute", "-o", &path("b.exr")][..],
        &common,
    ]
    .concat());
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let o = run(&[
        &[
            "irradiance",
            inp,
            "--order",
            "8",
            "--window",
            "auto",
            "-o",
            &path("s.exr"),
        ][..],
        &common,
    ]
    .concat());
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(String::from_utf8_lossy(&o.stdout).contains("irradiance is"));
    let opts = envlight::io::LoadOptions::default();
    let b = envlight::io::load(path("b.exr"), &opts).unwrap();
    let s = envlight::io::load(path("s.exr"), &opts).unwrap();
    assert_eq!((b.mapping, b.width), (Mapping::Cube, 4));
    for (x, y) in b.texels.iter().zip(&s.texels) {
        assert!((x[1] / y[1] - 1.0).abs() < 1e-3, "{x:?} vs {y:?}");
    }
    let o = run(&[
        &["prefilter", inp, "--phong", "10", "-o", &path("p.exr")][..],
        &common,
    ]
    .concat());
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let p = envlight::io::load(path("p.exr"), &opts).unwrap();
    assert!(p.texels.iter().flatten().all(|v| v.is_finite() && *v > 0.0));
    // Three levels by cmft's rule with scale 4, bias 0: n = 17, 5, 2 at sizes 4, 2, 1.
    let o = run(&[
        &[
            "prefilter",
            inp,
            "--phong-levels",
            "3",
            "--gloss-scale",
            "4",
            "--gloss-bias",
            "0",
            "-o",
            &path("lv.exr"),
        ][..],
        &common,
    ]
    .concat());
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let listing: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(path("lv.levels.json")).unwrap()).unwrap();
    let levels = listing["levels"].as_array().unwrap();
    assert_eq!(levels.len(), 3);
    for (k, (n, size)) in [(17.0, 4), (5.0, 2), (2.0, 1)].into_iter().enumerate() {
        assert_eq!(levels[k]["phong_exponent"].as_f64(), Some(n));
        let m = envlight::io::load(path(&format!("lv.level{k}.exr")), &opts).unwrap();
        assert_eq!((m.mapping, m.width), (Mapping::Cube, size));
        assert!(m.texels.iter().flatten().all(|v| v.is_finite() && *v > 0.0));
    }
    let o = run(&["prefilter", inp, "-o", &path("none.exr")]);
    assert!(!o.status.success());
    let o = run(&["irradiance", inp, "--window", "box", "-o", &path("x.exr")]);
    assert!(!o.status.success());
    assert!(String::from_utf8_lossy(&o.stderr).contains("unknown window"));
}

/// `envlight sh` writes the documented JSON, and its matrices reproduce its coefficients.
#[test]
fn sh_command_writes_the_documented_json() {
    let dir = std::path::PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("sh_cli");
    std::fs::create_dir_all(&dir).unwrap();
    let input = dir.join("smooth.exr");
    let map = EnvMap::from_fn(
        Mapping::LatLong,
        64,
        32,
        2,
        envlight::math::synth::smooth_env,
    );
    envlight::io::save_exr(&map, &input).unwrap();
    let out = dir.join("smooth_sh.json");
    let status = std::process::Command::new(env!("CARGO_BIN_EXE_envlight"))
        .args([
            "--validation",
            "sh",
            input.to_str().unwrap(),
            "--order",
            "3",
            "-o",
            out.to_str().unwrap(),
        ])
        .status()
        .unwrap();
    assert!(status.success());
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&out).unwrap()).unwrap();
    assert_eq!(json["order"], 3);
    let coeffs: Vec<[f64; 3]> = serde_json::from_value(json["coefficients"].clone()).unwrap();
    assert_eq!(coeffs.len(), 16);
    let cpu = sh::project(&map, 3);
    assert!(worst_vs_cpu(&coeffs, &cpu) < 1e-5);
    let r: [[f64; 4]; 4] =
        serde_json::from_value(json["irradiance_matrices"]["r"].clone()).unwrap();
    let red: Vec<f64> = coeffs[..9].iter().map(|c| c[0]).collect();
    let want = sh::irradiance_matrix(&red);
    for i in 0..4 {
        for j in 0..4 {
            // JSON parsers may round the last bit differently.
            assert!(
                (r[i][j] - want[i][j]).abs() <= 1e-14 * want[i][j].abs().max(1.0),
                "M[{i}][{j}]"
            );
        }
    }
}

/// The output's extension picks its format (`io::save_map`): `envlight convert` to `.hdr`
/// writes Radiance RGBE, to `.pfm` a PFM, to `.exr` OpenEXR, and each loads back as the
/// same map — a cube through its 1:6 strip, by aspect ratio alone for Radiance and PFM —
/// within the format's precision (RGBE: an 8-bit mantissa per channel under the exponent of
/// the texel's largest, so at most one step, 2⁻⁷ of the largest; float32 formats exactly). An extension envlight does not write, or
/// none, is refused by name before any work, and no file appears.
#[test]
fn convert_writes_the_format_its_output_names() {
    let exe = env!("CARGO_BIN_EXE_envlight");
    let dir = std::path::PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("convert_formats");
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let input = dir.join("smooth.exr");
    let map = EnvMap::from_fn(Mapping::LatLong, 48, 24, 2, smooth_env);
    envlight::io::save_exr(&map, &input).unwrap();
    let convert = |out: &std::path::Path| {
        std::process::Command::new(exe)
            .arg("--validation")
            .args([
                "convert",
                input.to_str().unwrap(),
                "--to",
                "cube",
                "--size",
                "8",
            ])
            .arg("-o")
            .arg(out)
            .output()
            .unwrap()
    };
    let opts = envlight::io::LoadOptions::default();
    let exr = dir.join("cube.exr");
    let o = convert(&exr);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let want = envlight::io::load(&exr, &opts).unwrap();
    assert_eq!(
        (want.mapping, want.width, want.height),
        (Mapping::Cube, 8, 8)
    );
    for (name, magic, tolerance) in [
        ("cube.hdr", &b"#?RADIANCE"[..], 2f64.powi(-7)),
        ("cube.pfm", &b"PF\n"[..], 0.0),
    ] {
        let path = dir.join(name);
        let o = convert(&path);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let bytes = std::fs::read(&path).unwrap();
        assert!(bytes.starts_with(magic), "{name}: {:?}", &bytes[..12]);
        let back = envlight::io::load(&path, &opts).unwrap();
        assert_eq!(
            (back.mapping, back.width, back.height),
            (Mapping::Cube, 8, 8)
        );
        // Each texel's largest channel error over its largest channel.
        let mut errors = common::compare::Errors::new();
        for (k, (b, w)) in back.texels.iter().zip(&want.texels).enumerate() {
            let top = common::compare::max_of(*w);
            assert!(top > 0.0, "{name} texel {k}");
            let e = common::compare::max_of((0..3).map(|c| (b[c] as f64 - w[c] as f64).abs()));
            errors.add(e / top, k);
        }
        assert_eq!(errors.count(), want.texels.len(), "{name}");
        errors.assert_within(tolerance, name);
    }
    for name in ["cube.png", "cube.tiff", "cube"] {
        let path = dir.join(name);
        let o = convert(&path);
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(!o.status.success(), "{name} accepted");
        assert!(err.contains(name) && err.contains(".exr"), "{name}: {err}");
        assert!(!path.exists(), "{name} was written");
    }
}
