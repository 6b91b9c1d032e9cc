//! examples/frame.rs: envlight's passes recorded into an engine's own command buffer, on the
//! engine's images, submitted once. The frame must equal what `envlight render` makes of the
//! same scene, with no validation message and no envlight object left behind.

mod common;
#[path = "../examples/frame.rs"]
mod frame_example;

use common::compare::Errors;
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
    let mut errors = Errors::new();
    for (k, (a, b)) in f.frame.texels.iter().zip(&cli.texels).enumerate() {
        for c in 0..3 {
            errors.rel(a[c], b[c], 1e-3, (k, c));
        }
    }
    let worst = errors.worst();
    assert!(
        worst <= 1e-6,
        "engine frame differs from the CLI render by {worst:e}"
    );
    let lit = f.frame.texels.iter().filter(|t| t[1] > 0.0).count();
    assert!(lit > f.frame.texels.len() / 2, "the frame is mostly black");
    let _ = std::fs::remove_dir_all(&dir);
}
