//! `envlight-lab scale`: what a bake costs against the source's resolution. A lat-long probe is
//! upsampled ×k (each texel repeated: the same picture at k² the texels), written as a
//! Radiance file, and baked by `envlight bake` in its own process at default settings:
//! whole-process seconds and peak RSS (the child's own, from `wait4`), the manifest's stages
//! and spot-check errors (the same content should bake the same cubes at every size).

use crate::common::Global;
use anyhow::{anyhow, bail, Context as _, Result};
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::Instant;

/// One factor's bake.
struct Row {
    width: u32,
    height: u32,
    seconds: f64,
    peak_bytes: u64,
    /// The manifest's entry of the probe.
    entry: serde_json::Value,
}

/// Runs `c` to its end with no output; its wall seconds and peak resident bytes.
fn measured(mut c: Command) -> Result<(f64, u64)> {
    let t0 = Instant::now();
    let child = c
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .context("starting envlight bake")?;
    let mut status = 0;
    // SAFETY: rusage is plain data, zero is a valid value of every field.
    let mut usage: libc::rusage = unsafe { std::mem::zeroed() };
    // SAFETY: the pid is this process's unwaited child; status and usage are valid pointers.
    let r = unsafe { libc::wait4(child.id() as libc::pid_t, &mut status, 0, &mut usage) };
    let seconds = t0.elapsed().as_secs_f64();
    if r < 0 {
        bail!(
            "waiting for envlight bake: {}",
            std::io::Error::last_os_error()
        );
    }
    if !(libc::WIFEXITED(status) && libc::WEXITSTATUS(status) == 0) {
        bail!("envlight bake failed (wait status {status}): run {c:?} to see why");
    }
    // Linux reports ru_maxrss in kibibytes.
    Ok((seconds, usage.ru_maxrss as u64 * 1024))
}

/// `map` with each texel repeated `k` × `k` times.
fn upsampled(map: &envlight::EnvMap, k: u32) -> Vec<image::Rgb<f32>> {
    let (w, h) = (map.width * k, map.height * k);
    let mut out = Vec::with_capacity((w * h) as usize);
    for j in 0..h {
        for i in 0..w {
            out.push(image::Rgb(map.texel(0, i / k, j / k)));
        }
    }
    out
}

/// Bakes `input` upsampled by each of `factors`; prints the table and, with `out`, writes
/// it as the page's "bake-scale" section.
pub fn bench_scale(g: &Global, input: &Path, factors: &[u32], out: Option<&PathBuf>) -> Result<()> {
    let map = envlight::io::load(input, &Default::default())?;
    if map.mapping != envlight::Mapping::LatLong {
        bail!(
            "{}: bench scale upsamples lat-long maps only",
            input.display()
        );
    }
    let scratch = std::env::temp_dir().join(format!("envlight-scale-{}", std::process::id()));
    let mut rows = Vec::new();
    for &k in factors {
        let dir = scratch.join(format!("x{k}"));
        std::fs::create_dir_all(&dir).with_context(|| dir.display().to_string())?;
        let hdr = dir.join("probe.hdr");
        let (w, h) = (map.width * k, map.height * k);
        {
            let f = std::fs::File::create(&hdr).with_context(|| hdr.display().to_string())?;
            image::codecs::hdr::HdrEncoder::new(std::io::BufWriter::new(f))
                .encode(&upsampled(&map, k), w as usize, h as usize)
                .with_context(|| hdr.display().to_string())?;
        }
        let baked = dir.join("out");
        let mut c = Command::new(crate::common::envlight_exe()?);
        if let Some(d) = &g.device {
            c.args(["--device", d]);
        }
        c.arg("bake").arg(&hdr).arg("-o").arg(&baked);
        let (seconds, peak_bytes) = measured(c)?;
        let manifest: serde_json::Value =
            serde_json::from_slice(&std::fs::read(baked.join("manifest.json"))?)?;
        let entry = manifest["probes"][0].clone();
        eprintln!(
            "×{k} ({w} × {h}): {seconds:.2} s, {:.0} MB",
            peak_bytes as f64 / 1e6
        );
        rows.push(Row {
            width: w,
            height: h,
            seconds,
            peak_bytes,
            entry,
        });
        let _ = std::fs::remove_dir_all(&dir);
    }
    let _ = std::fs::remove_dir_all(&scratch);
    let name = input.file_name().unwrap_or_default().to_string_lossy();
    let (method, md) = markdown(&name, &rows)?;
    print!("{method}\n\n{md}");
    if let Some(out) = out {
        let ctx = crate::common::context(g)?;
        let section = crate::page::Section {
            job: "bake-scale",
            title: "Bake time and memory against the source's resolution",
            method: &method,
            body: &md,
        };
        crate::page::write_section(out, &section, &crate::page::Provenance::of(ctx.info()))?;
    }
    Ok(())
}

/// The method line and the table.
fn markdown(name: &str, rows: &[Row]) -> Result<(String, String)> {
    let method = format!(
        "{name} upsampled ×k (each texel repeated: the same picture), written as \
         Radiance RGBE, baked by `envlight bake` at default settings in its own process, one \
         run each: whole-process seconds and the process's peak RSS (`wait4`), the manifest's \
         stages (read: reading, hashing, decoding; lights: statistics, extractions and grids; \
         upload: staging and recording; GPU wait; check: the spot check against float64 \
         exact filters; write) and the spot check's worst errors, which the same content \
         should keep at every size."
    );
    let mut md = String::from(
        "| source | seconds | peak RSS | bytes a texel | read | lights | upload | GPU wait | \
         GPU convert / filter ms | check | write | irradiance / specular error |\n\
         |---|---|---|---|---|---|---|---|---|---|---|---|\n",
    );
    for r in rows {
        let st = &r.entry["stages"];
        let s = |k: &str| -> Result<f64> {
            st[k]
                .as_f64()
                .ok_or_else(|| anyhow!("the manifest has no stage {k}: {}", r.entry))
        };
        let c = &r.entry["check"];
        let worst = c["specular"]
            .as_array()
            .map(|v| v.iter().filter_map(|x| x.as_f64()).fold(0.0, f64::max))
            .unwrap_or(f64::NAN);
        let texels = r.width as f64 * r.height as f64;
        md += &format!(
            "| {} × {} | {:.2} | {:.0} MB | {:.1} | {:.2} | {:.2} | {:.2} | {:.2} | {:.0} / {:.0} \
             | {:.2} | {:.2} | {:.2e} / {:.2e} |\n",
            r.width,
            r.height,
            r.seconds,
            r.peak_bytes as f64 / 1e6,
            r.peak_bytes as f64 / texels,
            s("read")?,
            s("lights")?,
            s("upload")?,
            s("gpu_wait")?,
            s("gpu_convert_ms")?,
            s("gpu_filter_ms")?,
            s("check")?,
            s("write")?,
            c["irradiance"].as_f64().unwrap_or(f64::NAN),
            worst,
        );
    }
    Ok((method, md))
}

/// `envlight-lab scale`: what a bake costs against the source's resolution: a lat-long probe
/// upsampled ×k (the same picture), baked in its own process: seconds, peak RSS, stages and
/// errors (markdown)
#[derive(clap::Args)]
pub struct ScaleArgs {
    /// A lat-long probe
    pub input: PathBuf,
    /// Upsampling factors
    #[arg(long, value_delimiter = ',', default_value = "1,4,8,16")]
    pub factors: Vec<u32>,
    /// The performance page (docs/performance/DEVICE.md) to write this job's section into
    #[arg(long)]
    pub out: Option<PathBuf>,
}
