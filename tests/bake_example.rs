//! examples/bake.rs: an asset pipeline baking in-process through the library's bake API must
//! write exactly the files `envlight bake` writes for the same settings.

#[path = "../examples/bake.rs"]
mod bake_example;
mod common;

use common::bake::{probes, temp, walk};
use std::path::{Path, PathBuf};
use std::process::Command;

/// The files under `root` by their path relative to it, manifests and probe records (times,
/// hashes of these same files) and the set's gallery (drawn from the manifests) left out.
fn files(root: &Path) -> Vec<(PathBuf, Vec<u8>)> {
    let mut v: Vec<(PathBuf, Vec<u8>)> = walk(root)
        .into_iter()
        .filter(|p| {
            let name = p.file_name().unwrap().to_string_lossy();
            !name.starts_with("manifest")
                && name != "probe.json"
                && name != "index.html"
                && !name.starts_with('.')
        })
        .map(|p| {
            (
                p.strip_prefix(root).unwrap().to_path_buf(),
                std::fs::read(&p).unwrap(),
            )
        })
        .collect();
    v.sort();
    v
}

#[test]
fn the_pipeline_example_writes_what_envlight_bake_writes() {
    let dir = temp("example");
    let inputs = dir.join("in");
    std::fs::create_dir_all(&inputs).unwrap();
    probes(&inputs);
    // A smooth map and the analytic sky, whose sun the settings keep apart in lights.json.
    let chosen = vec![inputs.join("p0.exr"), inputs.join("p1.exr")];

    let ctx = common::ctx();
    let mine = dir.join("example");
    let written = bake_example::bake(&ctx, &bake_example::settings(), &chosen, &mine).unwrap();
    common::finish(ctx);

    let cli = dir.join("cli");
    let o = Command::new(env!("CARGO_BIN_EXE_envlight"))
        .args(["--validation", "bake", "--out"])
        .arg(&cli)
        .args(&chosen)
        .args(["--preset", "bevy", "--lights", "separate", "--check", "0"])
        .args([
            "--specular-size",
            "32",
            "--irradiance-size",
            "8",
            "--samples",
            "16",
        ])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));

    let ours = files(&mine);
    let theirs = files(&cli);
    let names = |v: &[(PathBuf, Vec<u8>)]| v.iter().map(|(p, _)| p.clone()).collect::<Vec<_>>();
    assert_eq!(names(&ours), names(&theirs));
    assert_eq!(ours.len(), written.len());
    // Both probes' cubes, SH and skybox, and the sky's lights.
    assert!(
        names(&ours).contains(&PathBuf::from("p1.exr/lights.json")),
        "{:?}",
        names(&ours)
    );
    assert!(names(&ours).contains(&PathBuf::from("p0.exr/skybox.ktx2")));
    assert!(names(&ours).contains(&PathBuf::from("p1.exr/preview.png")));
    for ((path, a), (_, b)) in ours.iter().zip(&theirs) {
        assert!(a == b, "{} differs from envlight bake's", path.display());
    }
    let _ = std::fs::remove_dir_all(&dir);
}
