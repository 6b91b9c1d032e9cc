//! Project tasks: `cargo xtask <setup|test|demo|bench|lab|shaders|gen-assets|lint>`.
//!
//! `setup` installs what the project needs on a Debian-like system (idempotently); `test` and
//! `demo` run it first, so the README's two commands work on a fresh machine. `test --quick`
//! runs the inner-loop subset.

use std::process::{Command, ExitCode};

/// Debian packages: Vulkan loader, Mesa's lavapipe, validation layers; cmake, ninja and g++
/// for building shaderc from source (only `cargo xtask shaders` needs those); Slurm and munge
/// for the test that runs the farm script on a real single-node cluster (tests/slurm.rs starts
/// its own daemons, not the system's).
const PACKAGES: &[&str] = &[
    "libvulkan1",
    "mesa-vulkan-drivers",
    "vulkan-validationlayers",
    "cmake",
    "ninja-build",
    "g++",
    "python3",
    "slurm-wlm",
    "munge",
    // Headless, for the bake gallery's browser test (tests/gallery.rs).
    "chromium",
];

fn installed(pkg: &str) -> bool {
    Command::new("dpkg-query")
        .args(["-W", "-f=${Status}", pkg])
        .output()
        .map(|o| String::from_utf8_lossy(&o.stdout).contains("install ok installed"))
        .unwrap_or(false)
}

fn is_root() -> bool {
    Command::new("id")
        .arg("-u")
        .output()
        .map(|o| String::from_utf8_lossy(&o.stdout).trim() == "0")
        .unwrap_or(false)
}

fn setup() -> Result<(), String> {
    if Command::new("dpkg-query")
        .arg("--version")
        .output()
        .is_err()
    {
        return Err(
            "setup: this is not a Debian-like system (no dpkg). Install a Vulkan loader, \
                    Mesa's lavapipe driver, the Khronos validation layers, cmake and ninja with \
                    your package manager, then run again."
                .into(),
        );
    }
    let missing: Vec<&str> = PACKAGES.iter().copied().filter(|p| !installed(p)).collect();
    if missing.is_empty() {
        println!(
            "setup: all system packages present ({})",
            PACKAGES.join(", ")
        );
        return Ok(());
    }
    let cmd = format!(
        "apt-get update && apt-get install -y --no-install-recommends {}",
        missing.join(" ")
    );
    if !is_root() {
        return Err(format!(
            "setup: missing packages {missing:?}; run as root:\n  sudo sh -c '{cmd}'"
        ));
    }
    println!("setup: installing {missing:?}");
    let ok = Command::new("sh")
        .args(["-c", &cmd])
        .env("DEBIAN_FRONTEND", "noninteractive")
        .status()
        .map(|s| s.success())
        .unwrap_or(false);
    if !ok {
        return Err(format!("setup: '{cmd}' failed"));
    }
    Ok(())
}

fn cargo(args: &[&str]) -> Result<(), String> {
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    let status = Command::new(&cargo)
        .args(args)
        .status()
        .map_err(|e| format!("cannot run cargo: {e}"))?;
    if status.success() {
        Ok(())
    } else {
        Err(format!("cargo {} failed", args.join(" ")))
    }
}

/// The inner-loop subset of `test --quick` (under 2 minutes once built): the library's unit
/// tests and float64 oracles, input validation and bad files, the fuzz corpora, the layering
/// and plan checks, the tests' own hygiene and mutation matrix, and the quick GPU checks of
/// context teardown, mappings, GPU maps, the G-buffer and a set's bake.
const QUICK: &[&str] = &[
    "--lib",
    "--test",
    "bad_input",
    "--test",
    "fuzz_corpus",
    "--test",
    "layering",
    "--test",
    "honest",
    "--test",
    "mutation",
    "--test",
    "plan",
    "--test",
    "context",
    "--test",
    "mappings_gpu",
    "--test",
    "hard_cases",
    "--test",
    "map",
    "--test",
    "gbuffer",
    "--test",
    "bake_set",
];

/// `cargo test` (everything, or with `--quick` the [`QUICK`] subset), then a summary of the
/// tests that skipped their work (outside CI; in CI a skip is a failure). The whole run first
/// checks the embedder's build (no default features: no CLI, no BC6H encoder), which the
/// tests themselves never compile.
fn test(rest: &[&str]) -> Result<(), String> {
    let quick = rest.contains(&"--quick");
    if !quick {
        cargo(&[
            "check",
            "--no-default-features",
            "--all-targets",
            "-p",
            "envlight",
        ])?;
    }
    let mut args = vec!["test"];
    if quick {
        args.extend(QUICK);
    } else if rest.is_empty() {
        // The whole suite: the library's and the lab's tests (which run the `envlight`
        // program beside the lab's: one build makes both).
        args.extend(["-p", "envlight", "-p", "envlight-lab"]);
    }
    args.extend(rest.iter().filter(|a| **a != "--quick"));
    let log = std::env::temp_dir().join(format!("envlight-skips-{}.txt", std::process::id()));
    let _ = std::fs::remove_file(&log);
    std::env::set_var("ENVLIGHT_SKIP_LOG", &log);
    let result = cargo(&args);
    let skips = std::fs::read_to_string(&log).unwrap_or_default();
    let _ = std::fs::remove_file(&log);
    let mut lines: Vec<&str> = skips.lines().collect();
    lines.sort();
    if lines.is_empty() {
        println!("xtask test: no test skipped its work");
    } else {
        println!("xtask test: {} tests skipped their work:", lines.len());
        for l in lines {
            println!("  {l}");
        }
    }
    result
}

fn run(task: &str, rest: &[String]) -> Result<(), String> {
    let rest: Vec<&str> = rest.iter().map(String::as_str).collect();
    match task {
        "setup" => setup(),
        "test" => {
            setup()?;
            test(&rest)
        }
        "demo" => {
            setup()?;
            let mut args = vec!["run", "--release", "--bin", "envlight", "--", "demo"];
            args.extend(&rest);
            cargo(&args)
        }
        "bench" => {
            setup()?;
            let mut args = vec![
                "run",
                "--release",
                "--bin",
                "envlight",
                "--",
                "bench",
                "convert",
            ];
            args.extend(&rest);
            cargo(&args)
        }
        "lab" => {
            setup()?;
            // The lab runs the `envlight` program beside it for whole-process timings.
            cargo(&["build", "--release", "--bin", "envlight"])?;
            let mut args = vec!["run", "--release", "-p", "envlight-lab", "--"];
            args.extend(&rest);
            cargo(&args)
        }
        "shaders" => {
            setup()?;
            cargo(&["run", "--release", "-p", "envlight-shaderc"])
        }
        "gen-assets" => cargo(&["run", "--release", "-p", "envlight-assets"]),
        "lint" => {
            cargo(&["fmt", "--all", "--", "--check"])?;
            cargo(&[
                "clippy",
                "--workspace",
                "--all-targets",
                "--",
                "-D",
                "warnings",
            ])?;
            // The library's docs with every module public (`reference`): no broken or
            // private intra-doc link.
            std::env::set_var("RUSTDOCFLAGS", "-D warnings");
            cargo(&["doc", "--no-deps", "-p", "envlight", "--all-features"])
        }
        _ => Err(format!(
            "unknown task '{task}'; tasks: setup, test, demo, bench, shaders, gen-assets, lint"
        )),
    }
}

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let Some((task, rest)) = args.split_first() else {
        eprintln!("usage: cargo xtask <setup|test|demo|bench|lab|shaders|gen-assets|lint> [args]");
        return ExitCode::FAILURE;
    };
    // Tasks run from the workspace root whatever the caller's directory.
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    if let Err(e) = std::env::set_current_dir(&root) {
        eprintln!("xtask: cannot enter {}: {e}", root.display());
        return ExitCode::FAILURE;
    }
    match run(task, rest) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("{e}");
            ExitCode::FAILURE
        }
    }
}
