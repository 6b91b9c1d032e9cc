//! `envlight-lab formats`: what each KTX2 texel format and Zstandard cost and keep, per
//! probe: the bytes of its irradiance and specular cubes, and each specular level's relative
//! luminance error against the rgba32f cubes of the same bake (mean and worst texel), with the
//! share of power clamped away where a format cannot hold a texel.

use crate::common::{context, Global};
use anyhow::{Context as _, Result};
use envlight::bake::output::clamp_cube;
use envlight::bake::{BakeOptions, Baker};
use envlight::io::ktx2::{self, Ktx2Format, Ktx2Image, Supercompression};
use envlight::io::LoadOptions;
use envlight::math::envmap::luminance;
use envlight::Orientation;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};

/// The formats compared with rgba32f.
const FORMATS: [Ktx2Format; 4] = [
    Ktx2Format::Rgba16f,
    Ktx2Format::B10g11r11,
    Ktx2Format::E5b9g9r9,
    Ktx2Format::Bc6h,
];

/// One probe in one format.
struct Row {
    probe: String,
    format: Ktx2Format,
    /// Bytes of irradiance.ktx2 + specular.ktx2, as they are and with Zstandard.
    bytes: [usize; 2],
    /// rgba32f's bytes, as they are.
    full: usize,
    /// Per specular level: mean and worst relative luminance error.
    errors: Vec<(f64, f64)>,
    /// The largest share of a level's power clamped away.
    clamped: f64,
}

/// Relative luminance errors of `got` against `want` over texels whose luminance is above
/// 1e-6 of the level's brightest: (mean, worst).
fn errors(got: &[[f32; 4]], want: &[[f32; 4]]) -> (f64, f64) {
    let y = |t: &[f32; 4]| luminance([t[0] as f64, t[1] as f64, t[2] as f64]);
    let top = want.iter().map(y).fold(0.0, f64::max);
    let (mut sum, mut worst, mut n) = (0.0, 0.0f64, 0usize);
    for (g, w) in got.iter().zip(want) {
        let yw = y(w);
        if yw > 1e-6 * top {
            let e = (y(g) - yw).abs() / yw;
            sum += e;
            worst = worst.max(e);
            n += 1;
        }
    }
    (sum / n.max(1) as f64, worst)
}

/// A cube written in one format: its bytes as they are and with Zstandard, its levels as
/// decoded back, and the largest share of a level's power clamped away.
struct Encoded {
    bytes: [usize; 2],
    levels: Vec<Vec<[f32; 4]>>,
    clamped: f64,
}

/// One probe's cube (`size` at level 0) in `format`.
fn encode_cube(levels: &[Vec<[f32; 4]>], size: u32, format: Ktx2Format) -> Result<Encoded> {
    let mut clamped = levels.to_vec();
    let c = clamp_cube(format, size, &mut clamped);
    let img = Ktx2Image::cube(size, &clamped);
    let plain = ktx2::encode_with(&img, format, Supercompression::None)?;
    let zstd = ktx2::encode_with(&img, format, Supercompression::Zstd)?;
    let back = ktx2::decode(&plain)?;
    Ok(Encoded {
        bytes: [plain.len(), zstd.len()],
        levels: back.levels,
        clamped: c.worst(),
    })
}

/// Runs `envlight-lab formats`.
pub fn bench_formats(
    g: &Global,
    inputs: &[PathBuf],
    opts: &BakeOptions,
    out: Option<&Path>,
) -> Result<()> {
    let mut files = Vec::new();
    for p in inputs {
        if p.is_dir() {
            files.extend(envlight::io::probes_in(p)?);
        } else {
            files.push(p.clone());
        }
    }
    files.sort();
    let ctx = context(g)?;
    let baker = Baker::new(&ctx)?;
    let mut rows = Vec::new();
    for path in &files {
        let map = envlight::io::load(path, &LoadOptions::default())
            .with_context(|| path.display().to_string())?;
        let baked = baker.bake(&map, &Orientation::default(), opts)?;
        let probe = path
            .file_name()
            .map(|n| n.to_string_lossy().to_string())
            .unwrap_or_default();
        let irr = std::slice::from_ref(&baked.irradiance);
        let full = ktx2_bytes(irr, opts.irradiance_size, Ktx2Format::Rgba32f)?
            + ktx2_bytes(&baked.specular, opts.specular_size, Ktx2Format::Rgba32f)?;
        for format in FORMATS {
            let i = encode_cube(irr, opts.irradiance_size, format)?;
            let sp = encode_cube(&baked.specular, opts.specular_size, format)?;
            let errors = sp
                .levels
                .iter()
                .zip(&baked.specular)
                .map(|(g, w)| errors(g, w))
                .collect();
            rows.push(Row {
                probe: probe.clone(),
                format,
                bytes: [i.bytes[0] + sp.bytes[0], i.bytes[1] + sp.bytes[1]],
                full,
                errors,
                clamped: i.clamped.max(sp.clamped),
            });
        }
        eprintln!("{probe}: done");
    }
    let (method, report) = markdown(&rows, opts);
    print!("{method}\n\n{report}");
    if let Some(out) = out {
        let section = crate::page::Section {
            job: "formats",
            title: "KTX2 texel formats: size and error against rgba32f",
            method: &method,
            body: &report,
        };
        crate::page::write_section(out, &section, &crate::page::Provenance::of(ctx.info()))?;
    }
    Ok(())
}

fn ktx2_bytes(levels: &[Vec<[f32; 4]>], size: u32, format: Ktx2Format) -> Result<usize> {
    Ok(ktx2::encode(&Ktx2Image::cube(size, levels), format)?.len())
}

/// Totals per format: bytes against rgba32f and against e5b9g9r9, the range of Zstandard's
/// ratio over the probes, and the worst mean error at level 0.
fn summary(s: &mut String, rows: &[Row]) {
    let total = |f: Ktx2Format, k: usize| -> usize {
        rows.iter()
            .filter(|r| r.format == f)
            .map(|r| r.bytes[k])
            .sum()
    };
    let full: usize = rows
        .iter()
        .filter(|r| r.format == Ktx2Format::Rgba16f)
        .map(|r| r.full)
        .sum();
    let e5 = total(Ktx2Format::E5b9g9r9, 0) as f64;
    let _ = writeln!(
        s,
        "### Summary ({} probes)\n\n| format | bytes of rgba32f | of e5b9g9r9 | zstd: kept, per probe (least – most) | level 0 mean error, worst probe |\n|---|---|---|---|---|",
        rows.len() / FORMATS.len()
    );
    for f in FORMATS {
        let mine: Vec<&Row> = rows.iter().filter(|r| r.format == f).collect();
        let z = |r: &&Row| r.bytes[1] as f64 / r.bytes[0] as f64;
        let zmin = mine.iter().map(z).fold(f64::INFINITY, f64::min);
        let zmax = mine.iter().map(z).fold(0.0, f64::max);
        let e0 = mine.iter().map(|r| r.errors[0].0).fold(0.0, f64::max);
        let _ = writeln!(
            s,
            "| {} | {:.4} | {:.4} | {:.3} – {:.3} | {:.1e} |",
            f.name(),
            total(f, 0) as f64 / full.max(1) as f64,
            total(f, 0) as f64 / e5,
            zmin,
            zmax,
            e0
        );
    }
    let _ = writeln!(s);
}

/// The report: per format, a row per probe with sizes and errors, and the totals.
/// The method and the tables.
fn markdown(rows: &[Row], opts: &BakeOptions) -> (String, String) {
    let mut s = String::new();
    let method = format!(
        "per probe, `irradiance.ktx2` ({0}²) + \
         `specular.ktx2` ({1}², {2} levels) baked once (lights extracted, {3} samples), then \
         written in each format. Bytes as written and with `--zstd`; error: relative luminance \
         error of each specular texel against the rgba32f cube (texels above 1e-6 of the \
         level's brightest), mean / worst, at level 0, the middle level and the last; clamped: \
         the largest share of a level's power clamped away.",
        opts.irradiance_size, opts.specular_size, opts.specular_levels, opts.samples
    );
    summary(&mut s, rows);
    for format in FORMATS {
        let _ = writeln!(
            s,
            "### {}\n\n| probe | bytes | of rgba32f | with zstd | level 0 mean / worst | level {} | level {} | clamped |\n|---|---|---|---|---|---|---|---|",
            format.name(),
            opts.specular_levels / 2,
            opts.specular_levels - 1
        );
        let mut total = [0usize; 3];
        for r in rows.iter().filter(|r| r.format == format) {
            let e = |k: usize| {
                let (m, w) = r.errors[k.min(r.errors.len() - 1)];
                format!("{m:.1e} / {w:.1e}")
            };
            let _ = writeln!(
                s,
                "| {} | {} | {:.3} | {} ({:.2}) | {} | {} | {} | {:.2e} |",
                r.probe,
                r.bytes[0],
                r.bytes[0] as f64 / r.full as f64,
                r.bytes[1],
                r.bytes[1] as f64 / r.bytes[0] as f64,
                e(0),
                e(r.errors.len() / 2),
                e(r.errors.len() - 1),
                r.clamped
            );
            total[0] += r.bytes[0];
            total[1] += r.bytes[1];
            total[2] += r.full;
        }
        let _ = writeln!(
            s,
            "| **all** | {} | {:.3} | {} ({:.2}) | | | | |\n",
            total[0],
            total[0] as f64 / total[2].max(1) as f64,
            total[1],
            total[1] as f64 / total[0].max(1) as f64
        );
    }
    (method, s)
}

/// `envlight-lab formats`: what each KTX2 texel format and Zstandard cost and keep: per
/// probe the bytes of its cubes and each specular level's error against rgba32f (markdown)
#[derive(clap::Args)]
pub struct FormatsArgs {
    /// Probes, or folders whose .hdr/.exr/.dds/.pfm files are all taken
    #[arg(required = true)]
    inputs: Vec<PathBuf>,
    /// Specular cube face size at level 0
    #[arg(long, default_value_t = 256)]
    specular_size: u32,
    /// Specular levels
    #[arg(long, default_value_t = 8)]
    specular_levels: u32,
    /// Irradiance cube face size
    #[arg(long, default_value_t = 32)]
    irradiance_size: u32,
    /// The performance page (docs/performance/DEVICE.md) to write this job's section into
    #[arg(long)]
    out: Option<PathBuf>,
}

/// Runs `envlight-lab formats`.
pub fn run(g: &Global, a: &FormatsArgs) -> Result<()> {
    let mut opts = BakeOptions::default();
    opts.specular_size = a.specular_size;
    opts.specular_levels = a.specular_levels;
    opts.irradiance_size = a.irradiance_size;
    opts.validate()?;
    bench_formats(g, &a.inputs, &opts, a.out.as_deref())
}
