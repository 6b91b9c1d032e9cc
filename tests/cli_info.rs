//! `envlight lights`: the report of what extraction takes from a map.

mod common;

use envlight::math::synth::Sky;
use envlight::math::Mapping;
use envlight::EnvMap;
use glam::DVec3;

/// `envlight lights --json` on a written sky names one light in the sun's direction with its
/// share (with `--fill 2`, more texels and a larger share); a missing file is an error naming
/// it, not a panic.
#[test]
fn lights_command_reports_the_sun() {
    let dir = std::env::temp_dir().join(format!("envlight-lights-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("sky.exr");
    let sky = envlight::math::synth::Sky::default();
    let map = EnvMap::from_fn(Mapping::LatLong, 256, 128, 2, |d| sky.radiance(d));
    envlight::io::save_exr(&map, &path).unwrap();
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_envlight"))
        .args(["lights", path.to_str().unwrap(), "--json"])
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let lights = v["lights"].as_array().unwrap();
    assert_eq!(lights.len(), 1, "{v}");
    let d: Vec<f64> = lights[0]["direction"]
        .as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_f64().unwrap())
        .collect();
    let sun = Sky::default().sun_dir;
    assert!(DVec3::new(d[0], d[1], d[2]).dot(sun) > 0.999, "{d:?}");
    let share = lights[0]["share"].as_f64().unwrap();
    assert!(share > 0.5 && share < 1.0, "{share}");
    // --fill grows the light set around the sun and gives it more of the power.
    let filled = std::process::Command::new(env!("CARGO_BIN_EXE_envlight"))
        .args(["lights", path.to_str().unwrap(), "--json", "--fill", "2"])
        .output()
        .unwrap();
    assert!(filled.status.success());
    let f: serde_json::Value = serde_json::from_slice(&filled.stdout).unwrap();
    assert_eq!(f["options"]["fill"].as_u64(), Some(2), "{f}");
    let count = |v: &serde_json::Value| v["light_texels"].as_u64().unwrap();
    assert!(count(&f) > count(&v), "{} {}", count(&f), count(&v));
    let fshare = f["lights"][0]["share"].as_f64().unwrap();
    assert!(fshare > share && fshare <= 1.0, "{fshare} {share}");
    let missing = std::process::Command::new(env!("CARGO_BIN_EXE_envlight"))
        .args(["lights", dir.join("none.hdr").to_str().unwrap()])
        .output()
        .unwrap();
    assert!(!missing.status.success());
    assert!(String::from_utf8_lossy(&missing.stderr).contains("none.hdr"));
    let _ = std::fs::remove_dir_all(&dir);
}

/// `envlight --help` and `envlight bench --help` list the user's jobs: no peer tool (cmft,
/// glTF-IBL-Sampler) and none of the lab's commands, which `cargo xtask lab` runs.
#[test]
fn help_lists_the_users_jobs_only() {
    let exe = env!("CARGO_BIN_EXE_envlight");
    for args in [&["--help"][..], &["bench", "--help"][..]] {
        let o = std::process::Command::new(exe).args(args).output().unwrap();
        assert!(o.status.success());
        let text = String::from_utf8_lossy(&o.stdout).to_lowercase();
        assert!(text.contains("commands:"), "{text}");
        for name in [
            "cmft",
            "ibl",
            "sampler",
            "peers",
            "formats",
            "scale",
            "fis ",
            "accuracy ",
            "accuracy table",
        ] {
            assert!(!text.contains(name), "{args:?} names {name}:\n{text}");
        }
    }
    for job in [
        "info",
        "convert",
        "irradiance",
        "prefilter",
        "bake",
        "render",
        "report",
        "bench",
    ] {
        let o = std::process::Command::new(exe)
            .args(["help"])
            .output()
            .unwrap();
        let text = String::from_utf8_lossy(&o.stdout).into_owned();
        assert!(text.contains(&format!("  {job} ")), "no {job}:\n{text}");
    }
}
