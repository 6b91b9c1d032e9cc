//! The command line on bad input: a missing driver, non-finite options, a closed pipe and
//! probes or peers that only the user may name each end with a clear message, never a panic.

mod common;

use std::path::Path;

/// With no Vulkan driver the program says what to install (checked in a child process, since
/// the loader reads its driver list from the environment once).
#[test]
fn missing_driver_names_what_to_install() {
    let exe = env!("CARGO_BIN_EXE_envlight");
    let out = std::process::Command::new(exe)
        .arg("devices")
        .env("VK_DRIVER_FILES", "/nonexistent/envlight_icd.json")
        .env("VK_ICD_FILENAMES", "/nonexistent/envlight_icd.json")
        .env_remove("ENVLIGHT_DEVICE")
        .output()
        .unwrap();
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("mesa-vulkan-drivers"), "stderr: {err}");
    assert!(!err.contains("panicked"), "stderr: {err}");
}

/// Non-finite numbers on the command line are refused by the parser, naming the option.
#[test]
fn non_finite_options_are_refused() {
    let exe = env!("CARGO_BIN_EXE_envlight");
    let input = Path::new(env!("CARGO_MANIFEST_DIR")).join("assets/sky_latlong.exr");
    let out = std::path::PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("never_written.exr");
    for (args, flag) in [
        (
            &[
                "convert",
                "--to",
                "cube",
                "--size",
                "4",
                "--rotate-y",
                "nan",
            ][..],
            "--rotate-y",
        ),
        (
            &[
                "convert",
                "--to",
                "cube",
                "--size",
                "4",
                "--exposure",
                "inf",
            ][..],
            "--exposure",
        ),
        (
            &["prefilter", "--phong", "inf", "--to", "cube", "--size", "4"][..],
            "--phong",
        ),
        (&["sh", "--rotate-y=-inf"][..], "--rotate-y"),
    ] {
        let o = std::process::Command::new(exe)
            .args(&args[..1])
            .arg(&input)
            .args(&args[1..])
            .arg("-o")
            .arg(&out)
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(!o.status.success(), "{args:?} succeeded");
        assert!(
            err.contains(flag) && err.contains("finite"),
            "{args:?}: {err}"
        );
        assert!(!out.exists());
    }
}

/// A reader that stops early (`envlight lights MAP | head`) ends the command quietly, as it
/// ends other Unix tools, instead of a panic in println! on the closed pipe. The pipe is
/// closed before the command has loaded its map, so its first line meets it closed.
#[cfg(unix)]
#[test]
fn a_closed_pipe_ends_output_without_a_panic() {
    let exe = env!("CARGO_BIN_EXE_envlight");
    let input = Path::new(env!("CARGO_MANIFEST_DIR")).join("assets/sky_latlong.exr");
    let mut child = std::process::Command::new(exe)
        .arg("lights")
        .arg(&input)
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    drop(child.stdout.take());
    let out = child.wait_with_output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!err.contains("panicked"), "stderr: {err}");
}

/// Commands that read the user's probes take them from flags or environment variables, never
/// from a path of the developers' checkout: `report` without `--probes` or `ENVLIGHT_PROBES`
/// says what it needs.
#[test]
fn probes_come_from_the_user() {
    let exe = env!("CARGO_BIN_EXE_envlight");
    let o = std::process::Command::new(exe)
        .args(["--device", "cpu", "report", "--quick", "--out"])
        .arg(std::env::temp_dir().join("envlight-report-no-probes"))
        .env_remove("ENVLIGHT_PROBES")
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success() && err.contains("--probes"), "{err}");
}
