//! examples/dynamic.rs: an engine renders its own sky, its sun moving, into its own cube
//! image every frame and records envlight's resident render of a scene lit by it (diffuse by
//! SH, GGX by FIS and by split-sum) into the same command buffer. Each frame must equal what
//! `envlight render` makes of that frame's sky, one submission a frame (the engine's), none by
//! envlight, nothing created by envlight after the first frame, no validation message, no
//! envlight object left behind, and the sun's highlight must move with the sun.

mod common;
#[path = "../examples/dynamic.rs"]
mod dynamic_example;

use common::compare::frame_errors;
use envlight::EnvMap;
use std::path::Path;

const FRAMES: usize = 3;

/// The centroid column of the pixels at least half as bright as the brightest in columns
/// `cols` of `frame`: where the sun's highlight sits on the sphere those columns show.
fn highlight_column(frame: &EnvMap, cols: std::ops::Range<u32>) -> f64 {
    let lum = |i: u32, j: u32| frame.texels[(j * frame.width + i) as usize][1] as f64;
    let pixels: Vec<(u32, f64)> = (0..frame.height)
        .flat_map(|j| cols.clone().map(move |i| (i, j)))
        .map(|(i, j)| (i, lum(i, j)))
        .collect();
    let peak = common::compare::max_of(pixels.iter().map(|p| p.1));
    let bright: Vec<&(u32, f64)> = pixels.iter().filter(|p| p.1 >= 0.5 * peak).collect();
    let weight: f64 = bright.iter().map(|p| p.1).sum();
    bright.iter().map(|p| p.0 as f64 * p.1).sum::<f64>() / weight
}

#[test]
fn an_engine_loop_renders_every_frame_from_its_own_sky() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let scene = root.join("assets/scenes/dynamic.toml");
    let run = dynamic_example::run(&scene, FRAMES).unwrap();
    assert_eq!(
        run.warnings, 0,
        "validation warnings on the engine's device"
    );
    assert_eq!(run.leaked, 0, "envlight objects left behind");
    assert_eq!(run.engine_submissions, FRAMES, "one submission a frame");
    assert_eq!(run.envlight_submissions, 0, "envlight submitted work");
    assert_eq!(
        run.created_after_first, 0,
        "envlight created objects after frame 1"
    );
    assert_eq!(run.frames.len(), FRAMES);

    // Each frame against `envlight render` of the sky it was lit by (the scene's file swapped
    // for that sky): the same passes on the same map, so f32 rounding (1e-6 relative, floor
    // 1e-3), as tests/frame.rs finds for the static frame.
    let dir = std::env::temp_dir().join(format!("envlight-dynamic-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let text = std::fs::read_to_string(&scene).unwrap();
    assert!(text.contains("file = \"../sky_latlong.exr\""));
    for (k, (frame, sky)) in run.frames.iter().zip(&run.skies).enumerate() {
        let sky_path = dir.join(format!("sky_{k}.exr"));
        envlight::io::save_exr(sky, &sky_path).unwrap();
        let scene_k = dir.join(format!("scene_{k}.toml"));
        let swapped = text.replace("../sky_latlong.exr", &format!("sky_{k}.exr"));
        std::fs::write(&scene_k, swapped).unwrap();
        let out = dir.join(format!("cli_{k}.exr"));
        let cli = common::scenes::cli_render(&scene_k, &out);
        let errors = frame_errors(frame, &cli);
        assert!(
            errors.worst() <= 1e-6,
            "frame {k} differs from the CLI render of its sky by {:e} at {:?}",
            errors.worst(),
            errors.at()
        );
    }

    // The sun swings from left to right behind the camera: the highlight on the FIS sphere
    // (centre column 32) and on the split-sum one (centre 51) moves right with it, over a
    // pixel a frame (about 2.5 pixels by the mirror's geometry).
    for (name, cols) in [("FIS", 24..41), ("split-sum", 43..60)] {
        let at: Vec<f64> = run
            .frames
            .iter()
            .map(|f| highlight_column(f, cols.clone()))
            .collect();
        eprintln!("{name} highlight columns {at:?}");
        for w in at.windows(2) {
            assert!(w[1] > w[0] + 1.0, "{name} highlight columns {at:?}");
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
}
