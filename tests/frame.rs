//! examples/frame.rs: envlight's passes recorded into an engine's own command buffer, on the
//! engine's images, submitted once. The frame must equal what `envlight render` makes of the
//! same scene, with no validation message and no envlight object left behind.

mod common;
#[path = "../examples/frame.rs"]
mod frame_example;

use common::compare::frame_errors;
use std::path::Path;

#[test]
fn an_engine_frame_matches_the_cli_render() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let scene = root.join("assets/scenes/frame.toml");
    let f = frame_example::run(&scene).unwrap();
    assert_eq!(f.warnings, 0, "validation warnings on the engine's device");
    assert_eq!(f.leaked, 0, "envlight objects left behind");
    let labels: Vec<&str> = f.timings.iter().map(|t| t.label.as_str()).collect();
    assert!(
        labels.iter().any(|l| l.starts_with("convert")),
        "{labels:?}"
    );
    assert!(
        labels.contains(&"gbuffer") && labels.contains(&"shade"),
        "{labels:?}"
    );

    let dir = std::env::temp_dir().join(format!("envlight-frame-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let out = dir.join("cli.exr");
    let cli = common::scenes::cli_render(&scene, &out);
    assert_eq!((cli.width, cli.height), (f.frame.width, f.frame.height));
    // The same passes with the same inputs on the same device: only how the commands were
    // grouped into submissions differs, so the pixels agree to f32 rounding (1e-6 relative,
    // with a floor for dark pixels).
    let worst = frame_errors(&f.frame, &cli).worst();
    assert!(
        worst <= 1e-6,
        "engine frame differs from the CLI render by {worst:e}"
    );
    let lit = f.frame.texels.iter().filter(|t| t[1] > 0.0).count();
    assert!(lit > f.frame.texels.len() / 2, "the frame is mostly black");
    let _ = std::fs::remove_dir_all(&dir);
}

/// `envlight render --resident` (the map uploaded once, the frame recorded from the GPU image)
/// makes the CLI's host render of the same scene: the same passes on the same map for
/// assets/scenes/dynamic.toml (lights left in the map), but for its FIS paraboloid, which the
/// resident path converts from a plan (float64 weights, within 3e-6 of the conversion's twin)
/// and the host path without (float32 geometry, within 5e-5): 1e-4 at the worst pixel, 5e-6
/// on average, 1.5e-5 RMS (measured 3.3e-5, 2.0e-6, 5.0e-6; 0 with the plan left out); within
/// 1e-4 for diffuse.toml, whose
/// SH objects take lights extracted on the GPU (its clusters, the residual's SH) where the host
/// subtracts the light texels' coefficients. split_sum.toml's split-sum and FIS take the
/// chain's lights, which the resident path extracts on the GPU (its light tree over a spatial
/// order) and the host on the host (its tree by median splits), both filling the residual:
/// within 1e-5 on average, 1e-4 RMS and 1e-2 at the worst pixel (measured 1.7e-6, 1.5e-5,
/// 1.9e-3; with the GPU's residual clamped, 2.7e-4, 1.0e-3, 4.7e-2). It refuses a scene with
/// Monte Carlo, saying why.
#[test]
fn render_resident_matches_render() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let dir = std::env::temp_dir().join(format!("envlight-resident-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    // (worst, mean, RMS) bounds. split_sum.toml's split-sum and FIS take the chain's lights,
    // whose trees differ by their budgets (see above).
    let cases = [
        ("dynamic", [1e-4, 5e-6, 1.5e-5]),
        ("diffuse", [1e-4; 3]),
        ("split_sum", [1e-2, 1e-5, 1e-4]),
    ];
    for (name, [top, mean, rms]) in cases {
        let scene = root.join(format!("assets/scenes/{name}.toml"));
        let host = common::scenes::cli_render(&scene, &dir.join("host.exr"));
        let o = std::process::Command::new(env!("CARGO_BIN_EXE_envlight"))
            .args(["--validation", "--device", "cpu", "render", "--resident"])
            .arg(&scene)
            .arg("-o")
            .arg(dir.join("resident.exr"))
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let out = String::from_utf8_lossy(&o.stdout);
        assert_eq!(out.contains("light extraction"), name != "dynamic", "{out}");
        let resident = envlight::io::load(dir.join("resident.exr"), &Default::default()).unwrap();
        let errors = frame_errors(&resident, &host);
        eprintln!(
            "{name}: resident differs by {:.1e} at worst ({:?}), {:.1e} on average, {:.1e} RMS",
            errors.worst(),
            errors.at(),
            errors.mean(),
            errors.rms()
        );
        assert!(
            errors.worst() <= top && errors.mean() <= mean && errors.rms() <= rms,
            "{name}: resident differs by {:e} at worst ({:?}), {:e} on average, {:e} RMS",
            errors.worst(),
            errors.at(),
            errors.mean(),
            errors.rms()
        );
    }
    let mut mc = std::fs::read_to_string(root.join("assets/scenes/materials.toml")).unwrap();
    mc = mc.replace("\"../", &format!("\"{}/assets/", root.display()));
    std::fs::write(dir.join("mc.toml"), mc).unwrap();
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_envlight"))
        .args(["--device", "cpu", "render", "--resident"])
        .arg(dir.join("mc.toml"))
        .arg("-o")
        .arg(dir.join("refused.exr"))
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success() && err.contains("Monte Carlo"), "{err}");
    assert!(!dir.join("refused.exr").exists());
    let _ = std::fs::remove_dir_all(&dir);
}
