//! Performance pages (`docs/performance/<device>.md`), one per device, written only by
//! `cargo xtask lab … --out PAGE`: a header naming the device and its driver, then one section
//! per job, headed by the commit, date, CPU, command and method that measured it (lavapipe
//! rasterises on the host's cores, so one device's page may hold several machines' figures). A rerun
//! of a bench replaces its own section and leaves the others; the history of the figures is
//! `git log -p` of the page. A page of one device refuses a run on another.

use anyhow::{bail, Context as _, Result};
use std::fmt::Write as _;
use std::path::Path;

/// The jobs' order on a page (others follow, by name).
const ORDER: [&str; 4] = ["floors", "peers", "ibl", "formats"];

/// Where and when a section's figures were measured.
pub struct Provenance {
    /// The Vulkan device and its driver.
    pub device: String,
    /// The CPU's model name and its cores.
    pub cpu: String,
    /// The commit of the code measured.
    pub commit: String,
    /// The day, UTC (YYYY-MM-DD).
    pub date: String,
    /// The command line that measured it.
    pub command: String,
}

impl Provenance {
    /// This process on `info`'s device, now.
    pub fn of(info: &envlight::gpu::DeviceInfo) -> Provenance {
        let cores = std::thread::available_parallelism().map_or(0, |n| n.get());
        let quote = |a: String| match a.contains(' ') {
            true => format!("'{a}'"),
            false => a,
        };
        Provenance {
            device: format!("{} (driver {})", info.name, info.driver.trim()),
            cpu: format!("{}, {cores} cores", cpu_name()),
            commit: crate::common::commit(),
            date: today(),
            command: std::iter::once("cargo xtask lab".to_string())
                .chain(std::env::args().skip(1).map(quote))
                .collect::<Vec<_>>()
                .join(" "),
        }
    }
}

/// The CPU's model name, from /proc/cpuinfo.
pub fn cpu_name() -> String {
    std::fs::read_to_string("/proc/cpuinfo")
        .ok()
        .and_then(|t| {
            t.lines()
                .find(|l| l.starts_with("model name"))
                .and_then(|l| l.split(':').nth(1))
                .map(|s| s.trim().to_string())
        })
        .unwrap_or_else(|| "unknown".into())
}

/// Today's date, UTC, as YYYY-MM-DD (the civil calendar from days since 1970-01-01).
fn today() -> String {
    let secs = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.as_secs());
    let (y, m, d) = civil(secs.div_euclid(86_400) as i64);
    format!("{y:04}-{m:02}-{d:02}")
}

/// Year, month and day of `days` since 1970-01-01 (proleptic Gregorian).
fn civil(days: i64) -> (i64, u32, u32) {
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z - era * 146_097;
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = (doy - (153 * mp + 2) / 5 + 1) as u32;
    let m = if mp < 10 { mp + 3 } else { mp - 9 } as u32;
    (yoe + era * 400 + (m <= 2) as i64, m, d)
}

/// One job's section: its heading, what measured it, and its tables.
pub struct Section<'a> {
    /// The job's key on the page (`peers`, `ibl`, `formats`).
    pub job: &'a str,
    /// Its heading.
    pub title: &'a str,
    /// How it was measured (runs, medians, what the error is against).
    pub method: &'a str,
    /// Its tables and notes, markdown.
    pub body: &'a str,
}

/// What a header says of CPUs: each section names its own.
const CPU_PER_SECTION: &str = "each section names the one it ran on";

/// What a header adds of the CPU that sections naming none ran on.
const CPU_OF_THE_REST: &str = "; those that name none ran on ";

/// The page's header for `p`'s device; `unnamed` is the CPU of the sections that name none
/// (written before sections named theirs), if any.
fn header(p: &Provenance, unnamed: Option<&str>) -> String {
    let rest = unnamed.map_or(String::new(), |cpu| format!("{CPU_OF_THE_REST}{cpu}"));
    format!(
        "# envlight on {0}\n\nDevice: {0}. CPU: {CPU_PER_SECTION}{rest}.\n\n\
         Written by `cargo xtask lab … --out` only: each section names the commit, date, CPU, \
         command and method that measured it, and a rerun of its bench replaces it. Earlier \
         figures: `git log -p` of this file.\n",
        p.device
    )
}

/// The CPU that `old`'s sections naming none ran on: a page's header named one CPU for the
/// whole page before sections named theirs.
fn unnamed_cpu(old: &str) -> Option<String> {
    let line = old.lines().find(|l| l.starts_with("Device: "))?;
    let cpu = line.split_once(". CPU: ")?.1.trim_end_matches('.');
    match cpu.strip_prefix(CPU_PER_SECTION) {
        Some(rest) => rest.strip_prefix(CPU_OF_THE_REST).map(str::to_string),
        None => Some(cpu.to_string()),
    }
}

fn markers(job: &str) -> (String, String) {
    (
        format!("<!-- bench:{job} -->"),
        format!("<!-- /bench:{job} -->"),
    )
}

/// The sections of an existing page, by job.
fn sections(page: &str) -> Vec<(String, String)> {
    let mut out = Vec::new();
    let mut rest = page;
    while let Some(k) = rest.find("<!-- bench:") {
        let tail = &rest[k + "<!-- bench:".len()..];
        let Some(job) = tail.split(" -->").next().map(str::to_string) else {
            break;
        };
        let (open, close) = markers(&job);
        let Some(end) = rest[k..].find(&close) else {
            break;
        };
        let text = rest[k..k + end + close.len()].to_string();
        debug_assert!(text.starts_with(&open));
        out.push((job, text));
        rest = &rest[k + end + close.len()..];
    }
    out
}

/// Writes `s` into the page at `path` (created if absent) as measured by `p`, replacing the
/// job's earlier section; refuses a page another device wrote.
pub fn write_section(path: &Path, s: &Section<'_>, p: &Provenance) -> Result<()> {
    let old = match std::fs::read_to_string(path) {
        Ok(t) => t,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => String::new(),
        Err(e) => return Err(e).with_context(|| path.display().to_string()),
    };
    let device_line = format!("Device: {}.", p.device);
    if let Some(theirs) = old.lines().find(|l| l.starts_with("Device: ")) {
        if !theirs.starts_with(&device_line) {
            bail!(
                "{}: a page of another device ({theirs}); this run is on {}: give a page of \
                 its own (docs/performance/<device>.md)",
                path.display(),
                p.device
            );
        }
    }
    let (open, close) = markers(s.job);
    let mut mine = String::new();
    let _ = write!(
        mine,
        "{open}\n## {}\n\nCommit {}, {}, {}: `{}`.\n\nMethod: {}\n\n{}\n{close}",
        s.title,
        p.commit,
        p.date,
        p.cpu,
        p.command,
        s.method,
        s.body.trim_end()
    );
    let mut all: Vec<(String, String)> = sections(&old)
        .into_iter()
        .filter(|(job, _)| job != s.job)
        .collect();
    all.push((s.job.to_string(), mine));
    let rank = |job: &str| ORDER.iter().position(|j| *j == job).unwrap_or(ORDER.len());
    all.sort_by(|a, b| (rank(&a.0), &a.0).cmp(&(rank(&b.0), &b.0)));
    let mut page = header(p, unnamed_cpu(&old).as_deref());
    for (_, text) in &all {
        let _ = write!(page, "\n{text}\n");
    }
    envlight::io::write_atomic(path, page.as_bytes())
        .with_context(|| format!("writing {}", path.display()))?;
    eprintln!("wrote the {} section of {}", s.job, path.display());
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn civil_dates_of_known_days() {
        assert_eq!(civil(0), (1970, 1, 1));
        assert_eq!(civil(11_016), (2000, 2, 29));
        assert_eq!(civil(20_785), (2026, 11, 28));
        assert_eq!(civil(-1), (1969, 12, 31));
    }

    fn prov(device: &str, commit: &str) -> Provenance {
        Provenance {
            device: device.into(),
            cpu: "a cpu, 2 cores".into(),
            commit: commit.into(),
            date: "2026-11-28".into(),
            command: "envlight bench x".into(),
        }
    }

    /// A rerun replaces its own section only; jobs keep their order; another device is refused.
    #[test]
    fn sections_are_replaced_in_place_and_devices_kept_apart() {
        let dir = std::env::temp_dir().join(format!("envlight-page-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let page = dir.join("dev.md");
        let _ = std::fs::remove_file(&page);
        let sec = |job, body| Section {
            job,
            title: "T",
            method: "m",
            body,
        };
        write_section(
            &page,
            &sec("formats", "| f 1 |"),
            &prov("gpu (driver 1)", "a1"),
        )
        .unwrap();
        write_section(
            &page,
            &sec("peers", "| p 1 |"),
            &prov("gpu (driver 1)", "a1"),
        )
        .unwrap();
        write_section(
            &page,
            &sec("formats", "| f 2 |"),
            &prov("gpu (driver 1)", "b2"),
        )
        .unwrap();
        let text = std::fs::read_to_string(&page).unwrap();
        assert!(!text.contains("| f 1 |") && text.contains("| f 2 |") && text.contains("| p 1 |"));
        assert!(
            text.find("| p 1 |") < text.find("| f 2 |"),
            "peers come first:\n{text}"
        );
        assert!(text.contains("Commit b2, 2026-11-28, a cpu, 2 cores: `envlight bench x`."));
        assert!(
            text.contains("CPU: each section names the one it ran on.\n"),
            "{text}"
        );
        assert_eq!(text.matches("<!-- bench:formats -->").count(), 1);
        let other = write_section(&page, &sec("peers", "x"), &prov("other (driver 2)", "c3"));
        assert!(other.unwrap_err().to_string().contains("another device"));
        let _ = std::fs::remove_dir_all(&dir);
    }

    /// A page whose header named one CPU for all its sections keeps that CPU for the sections
    /// that name none, through any number of reruns; a new section names its own.
    #[test]
    fn sections_name_their_cpu_and_older_ones_keep_the_headers() {
        let dir = std::env::temp_dir().join(format!("envlight-cpu-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let page = dir.join("dev.md");
        let old = "# envlight on gpu (driver 1)\n\nDevice: gpu (driver 1). CPU: Old CPU, 2 \
                   cores.\n\n<!-- bench:peers -->\n## P\n\nCommit a1, 2026-11-01: `x`.\n\
                   <!-- /bench:peers -->\n";
        std::fs::write(&page, old).unwrap();
        let sec = Section {
            job: "floors",
            title: "F",
            method: "m",
            body: "| f |",
        };
        for _ in 0..2 {
            write_section(&page, &sec, &prov("gpu (driver 1)", "b2")).unwrap();
            let text = std::fs::read_to_string(&page).unwrap();
            let want = "CPU: each section names the one it ran on; those that name none ran on \
                        Old CPU, 2 cores.\n";
            assert!(text.contains(want), "{text}");
            assert!(text.contains("Commit b2, 2026-11-28, a cpu, 2 cores: `envlight bench x`."));
            assert!(text.contains("Commit a1, 2026-11-01: `x`."), "{text}");
        }
        let _ = std::fs::remove_dir_all(&dir);
    }
}
