//! `envlight-lab floors` and `envlight-lab dynamic`: the user's own benchmarks of envlight's
//! passes (`envlight bench floors`, `envlight bench dynamic`), run as the program users run
//! and written as their sections of a device's performance page. The program prints its
//! method, a blank line, then its tables; the page takes the two as they are.

use crate::common::{context, envlight_exe, Global};
use crate::page::{write_section, Provenance, Section};
use anyhow::{bail, Context as _, Result};
use std::path::PathBuf;
use std::process::Command;

/// `envlight-lab floors`: every pass against its floor (`envlight bench floors`), as the
/// "floors" section of a performance page
#[derive(clap::Args)]
pub struct FloorsArgs {
    /// Lat-long widths of the source
    #[arg(long, value_delimiter = ',', default_value = "512,1024,2048")]
    sizes: Vec<u32>,
    /// Timed repetitions per case (the median is reported)
    #[arg(long, default_value_t = 3)]
    reps: usize,
    /// The performance page (docs/performance/DEVICE.md) to write the section into
    #[arg(long)]
    out: PathBuf,
}

/// `envlight-lab dynamic`: an environment that changes every frame (`envlight bench
/// dynamic`), as the "dynamic" (or, time-sliced, "dynamic-sliced") section of a page
#[derive(clap::Args)]
pub struct DynamicArgs {
    /// Cube inputs (face sides)
    #[arg(long, value_delimiter = ',', default_value = "64,128,256")]
    cubes: Vec<u32>,
    /// Lat-long inputs (widths)
    #[arg(long, value_delimiter = ',', default_value = "512,1024,2048")]
    widths: Vec<u32>,
    /// Sides of the GGX chain's cube
    #[arg(long, value_delimiter = ',', default_value = "128")]
    chain: Vec<u32>,
    /// FIS samples per chain texel
    #[arg(long, default_value_t = 128)]
    samples: u32,
    /// Spread the chain's rough levels over this many frames
    #[arg(long, default_value_t = 1)]
    slices: u32,
    /// Timed rounds of three frames each (the median is reported)
    #[arg(long, default_value_t = 3)]
    reps: usize,
    /// The performance page (docs/performance/DEVICE.md) to write the section into
    #[arg(long)]
    out: PathBuf,
}

fn list(v: &[u32]) -> String {
    v.iter().map(u32::to_string).collect::<Vec<_>>().join(",")
}

/// Runs `envlight bench ARGS` on the lab's device; its (method, tables).
fn bench(g: &Global, args: &[String]) -> Result<(String, String)> {
    let exe = envlight_exe()?;
    let mut c = Command::new(&exe);
    if let Some(d) = &g.device {
        c.args(["--device", d]);
    }
    if g.validation {
        c.arg("--validation");
    }
    c.arg("bench").args(args);
    let o = c
        .output()
        .with_context(|| format!("running {}", exe.display()))?;
    if !o.status.success() {
        bail!(
            "{} bench {} failed:\n{}",
            exe.display(),
            args.join(" "),
            String::from_utf8_lossy(&o.stderr)
        );
    }
    split(&String::from_utf8_lossy(&o.stdout))
}

/// A bench's output cut into its method (the first paragraph) and its tables.
fn split(out: &str) -> Result<(String, String)> {
    match out.split_once("\n\n") {
        Some((method, body)) if body.contains("|---|") => Ok((
            method.trim().to_string(),
            body.trim_end().to_string() + "\n",
        )),
        _ => bail!("envlight bench printed no method and table:\n{out}"),
    }
}

/// Runs `envlight-lab floors`.
pub fn floors(g: &Global, a: &FloorsArgs) -> Result<()> {
    let args = [
        "floors".into(),
        "--sizes".into(),
        list(&a.sizes),
        "--reps".into(),
        a.reps.to_string(),
    ];
    let (method, body) = bench(g, &args)?;
    print!("{method}\n\n{body}");
    let section = Section {
        job: "floors",
        title: "Every pass against its floor",
        method: &method,
        body: &body,
    };
    write_section(&a.out, &section, &Provenance::of(context(g)?.info()))
}

/// Runs `envlight-lab dynamic`.
pub fn dynamic(g: &Global, a: &DynamicArgs) -> Result<()> {
    let args = [
        "dynamic".into(),
        "--cubes".into(),
        list(&a.cubes),
        "--widths".into(),
        list(&a.widths),
        "--chain".into(),
        list(&a.chain),
        "--samples".into(),
        a.samples.to_string(),
        "--slices".into(),
        a.slices.to_string(),
        "--reps".into(),
        a.reps.to_string(),
    ];
    let (method, body) = bench(g, &args)?;
    print!("{method}\n\n{body}");
    let sliced = a.slices > 1;
    let section = Section {
        job: if sliced { "dynamic-sliced" } else { "dynamic" },
        title: if sliced {
            "An environment that changes every frame, its chain time-sliced"
        } else {
            "An environment that changes every frame"
        },
        method: &method,
        body: &body,
    };
    write_section(&a.out, &section, &Provenance::of(context(g)?.info()))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The method is the first paragraph; the rest, tables and notes, is the body; output
    /// without a table is refused rather than written as a section.
    #[test]
    fn a_bench_output_splits_into_method_and_tables() {
        let out = "GPU time from timestamps.\n\n| a | b |\n|---|---|\n| 1 | 2 |\n\nA note.\n";
        let (m, b) = split(out).unwrap();
        assert_eq!(m, "GPU time from timestamps.");
        assert_eq!(b, "| a | b |\n|---|---|\n| 1 | 2 |\n\nA note.\n");
        assert!(split("no table here\n\nnor here\n").is_err());
        assert!(split("one paragraph only").is_err());
    }
}
