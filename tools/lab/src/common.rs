//! What every lab command shares: the device options, the `envlight` program the whole-process
//! benchmarks run, the commit a page is made at, and medians.

use anyhow::{bail, Result};
use clap::Args;
use envlight::gpu::{Context, ContextOptions};
use std::path::PathBuf;

/// Options every lab command takes (as `envlight`'s own).
#[derive(Args, Clone)]
pub struct Global {
    /// Vulkan device: auto, cpu (lavapipe), an index, part of a name, or its UUID [env:
    /// ENVLIGHT_DEVICE]
    #[arg(long, global = true)]
    pub device: Option<String>,
    /// Enable the Vulkan validation layer
    #[arg(long, global = true)]
    pub validation: bool,
}

/// The device the options ask for (the pipeline cache `envlight` keeps, so that the lab's
/// timings see the same warm pipelines as the program's).
pub fn context(g: &Global) -> Result<Context> {
    let opts = ContextOptions::from_flags(g.device.as_deref(), g.validation);
    Ok(VALIDATION.context(&opts)?)
}

/// This process's contexts' validation logs.
static VALIDATION: envlight::gpu::ValidationRecord = envlight::gpu::ValidationRecord::new();

/// Messages the validation layer reported on this process's contexts, teardown included
/// (`main` fails the process on any, as `envlight` does).
pub fn validation_messages() -> Vec<String> {
    VALIDATION.messages()
}

/// The `envlight` program the whole-process benchmarks run: $ENVLIGHT_BIN, else the one beside
/// this program (cargo builds both into the same folder: `cargo xtask lab` does).
pub fn envlight_exe() -> Result<PathBuf> {
    if let Some(p) = std::env::var_os("ENVLIGHT_BIN") {
        return Ok(PathBuf::from(p));
    }
    let me = std::env::current_exe()?;
    let beside = me
        .parent()
        .map(|d| d.join(format!("envlight{}", std::env::consts::EXE_SUFFIX)));
    // Integration tests run from target/<profile>/deps; the program is one folder up.
    let above = me
        .parent()
        .and_then(|d| d.parent())
        .map(|d| d.join(format!("envlight{}", std::env::consts::EXE_SUFFIX)));
    match [beside, above].into_iter().flatten().find(|p| p.is_file()) {
        Some(p) => Ok(p),
        None => bail!(
            "the envlight program is not beside {}: build it (`cargo build --release`) or set \
             ENVLIGHT_BIN",
            me.display()
        ),
    }
}

/// The commit a page is made at: $ENVLIGHT_COMMIT, else `git rev-parse --short HEAD` in the
/// working directory, else the package version.
pub fn commit() -> String {
    std::env::var("ENVLIGHT_COMMIT")
        .ok()
        .or_else(|| {
            let o = std::process::Command::new("git")
                .args(["rev-parse", "--short", "HEAD"])
                .output()
                .ok()?;
            o.status
                .success()
                .then(|| String::from_utf8_lossy(&o.stdout).trim().to_string())
        })
        .unwrap_or_else(|| format!("envlight {}", env!("CARGO_PKG_VERSION")))
}

/// A float option that must be a finite number (clap's own parser takes "nan" and "inf").
pub fn finite_f64(s: &str) -> std::result::Result<f64, String> {
    match s.trim().parse::<f64>() {
        Ok(v) if v.is_finite() => Ok(v),
        Ok(v) => Err(format!("{v} is not a finite number")),
        Err(e) => Err(e.to_string()),
    }
}

/// The five numbers (loader, instance, device, rest, teardown) of the start-up line
/// `envlight devices` prints ("start-up ms: loader …, instance …, device …, rest …;
/// teardown ms …"), if `text` holds one.
pub fn parse_startup_line(text: &str) -> Option<[f64; 5]> {
    let line = text.lines().find(|l| l.starts_with("start-up ms: "))?;
    let mut v = line
        .split(|c: char| c == ',' || c == ';' || c == ':' || c.is_whitespace())
        .filter_map(|w| w.parse::<f64>().ok());
    let out = [v.next()?, v.next()?, v.next()?, v.next()?, v.next()?];
    v.next().is_none().then_some(out)
}

/// The folder of the probes: `given`, else $ENVLIGHT_PROBES.
pub fn probes_dir(given: Option<&std::path::Path>) -> Result<PathBuf> {
    given
        .map(PathBuf::from)
        .or_else(|| std::env::var_os("ENVLIGHT_PROBES").map(PathBuf::from))
        .ok_or_else(|| anyhow::anyhow!("which probes? Give --probes DIR or set ENVLIGHT_PROBES"))
}
