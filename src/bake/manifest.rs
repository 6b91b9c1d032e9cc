//! What a bake records of itself, so that a re-run, another shard or a retried job finds its
//! work done: the manifest (`OUT/manifest*.json`: the settings and their SHA-256, an entry per
//! probe with its outputs' sizes and SHA-256), each probe's own record (`OUT/NAME/probe.json`),
//! and the per-probe lock that keeps two runs from baking one probe at once.

use super::files::Clamps;
use super::output::{Irradiance, Preset};
use super::plan::{BakePlan, LightsMode};
use super::preview::PreviewCheck;
use super::{BakeOptions, SpotCheck};
use crate::error::{Error, Result};
use crate::io::ktx2::Supercompression;
use crate::io::write_atomic;
use crate::math::Orientation;
use serde::{Deserialize, Serialize};
use sha2::{Digest, Sha256};
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Everything that decides the outputs' bytes; its SHA-256 keys resumption.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Settings {
    /// The version of envlight that baked.
    pub envlight: String,
    /// What the GPU computed.
    pub options: BakeOptions,
    /// "ktx2" or "exr".
    pub format: String,
    /// The KTX2 texels' name.
    pub texels: String,
    /// The engine baked for.
    pub preset: Option<Preset>,
    /// World → file of the cube frame.
    pub orientation: Orientation,
    /// How the irradiance cube is normalised.
    pub irradiance: Irradiance,
    /// What became of the lights.
    pub lights: LightsMode,
    /// Whether the KTX2 levels are Zstandard-supercompressed.
    pub zstd: bool,
    /// `--max-source-side`, where given.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub max_source_side: Option<u32>,
    /// Whether previews are rendered (recorded only when off, so that a folder whose
    /// manifests lack the key keeps its settings hash and resumes).
    #[serde(default = "yes", skip_serializing_if = "is_yes")]
    pub preview: bool,
}

fn yes() -> bool {
    true
}

fn is_yes(b: &bool) -> bool {
    *b
}

impl Settings {
    /// The settings of a bake by `plan`.
    pub fn of(plan: &BakePlan) -> Settings {
        Settings {
            envlight: env!("CARGO_PKG_VERSION").into(),
            options: plan.options,
            format: plan.container.name().into(),
            texels: plan.texels.name().into(),
            preset: plan.preset,
            orientation: plan.orientation,
            irradiance: plan.irradiance,
            lights: plan.lights,
            zstd: plan.supercompression == Supercompression::Zstd,
            max_source_side: plan.max_source_side,
            preview: plan.preview,
        }
    }

    /// The SHA-256 of their JSON, which a manifest and each probe's record carry.
    pub fn sha256(&self) -> Result<String> {
        let json = serde_json::to_string(self)
            .map_err(|e| Error::Invalid(format!("bake settings as JSON: {e}")))?;
        Ok(sha256(json.as_bytes()))
    }
}

/// One output file in the manifest.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Output {
    /// Its path under the output folder, with `/` separators.
    pub file: String,
    /// Its size.
    pub bytes: u64,
    /// Its SHA-256, hex.
    pub sha256: String,
}

/// What failed a probe.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Failure {
    /// The input itself: unreadable, truncated, not a map envlight can filter.
    Input,
    /// The device or the system: retrying may succeed.
    System,
}

/// One probe in the manifest.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Entry {
    /// The input's path as given.
    pub input: String,
    /// The input's SHA-256.
    pub input_sha256: String,
    /// "baked", "skipped" or "failed".
    pub status: String,
    /// Why it failed.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub error: Option<String>,
    /// A failed probe's cause: its input (retrying cannot help) or the system (retry).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub failure: Option<Failure>,
    /// Its files.
    pub outputs: Vec<Output>,
    /// The run's wall time from the previous probe's end to this one's (they add up).
    pub seconds: f64,
    /// Of which the reader thread spent this long reading, hashing and decoding it
    /// alongside the GPU work.
    #[serde(default)]
    pub read_seconds: f64,
    /// GPU milliseconds of its bake.
    pub gpu_ms: f64,
    /// Errors against exact filters at a few texels (absent when not checked).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub check: Option<SpotCheck>,
    /// What clamping the cubes into the texel format took from them (absent when nothing
    /// was clamped or the format holds every value).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub clamped: Option<Clamps>,
    /// With `--lights separate`: the share of the map's power per channel the cubes leave to
    /// lights.json.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub separated: Option<[f64; 3]>,
    /// Seconds this run waited for the probe's lock, which another live bake held (absent
    /// where the lock was free: a killed holder's lock is dropped with its process).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub lock_wait_seconds: Option<f64>,
    /// Where a baked probe's time went (absent for skipped and failed probes).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub stages: Option<Stages>,
    /// How a source larger than `--max-source-side` or the device's largest image was
    /// reduced before baking (absent where it was baked as read).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub reduced: Option<Reduced>,
    /// The preview's check, files against intent (absent without a preview).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub preview: Option<PreviewCheck>,
}

impl Entry {
    /// An entry of `input` (its SHA-256 `input_sha256`) with `status`, nothing else recorded
    /// yet: no outputs, times zero, every optional part absent.
    pub fn new(input: String, input_sha256: String, status: &str) -> Entry {
        Entry {
            input,
            input_sha256,
            status: status.into(),
            error: None,
            failure: None,
            outputs: Vec::new(),
            seconds: 0.0,
            read_seconds: 0.0,
            gpu_ms: 0.0,
            check: None,
            clamped: None,
            separated: None,
            lock_wait_seconds: None,
            stages: None,
            reduced: None,
            preview: None,
        }
    }
}

/// A source reduced before its bake.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Reduced {
    /// Its size as read, (width, height).
    pub from: [u32; 2],
    /// The size baked.
    pub to: [u32; 2],
    /// The largest side allowed.
    pub limit: u32,
    /// `blocks K` (the means of K × K blocks) or `resampled` (a conversion scaled to the
    /// source's power).
    pub how: String,
}

/// Where a baked probe's time went: host seconds per stage, and the GPU's time per kind
/// of pass (timestamps). Reading runs on its own thread, beside the previous probe's work.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Stages {
    /// Reading, hashing and decoding the input.
    pub read: f64,
    /// Statistics, light extraction and the grids of block means.
    pub lights: f64,
    /// Staging the source (a large map's banded upload) and recording the submission.
    pub upload: f64,
    /// Waiting for the GPU's work and reading the cubes back.
    pub gpu_wait: f64,
    /// GPU milliseconds of the conversions: paraboloids, the clamp, their MIP chains.
    pub gpu_convert_ms: f64,
    /// GPU milliseconds of the filters: SH, the irradiance cube, the specular levels, lights.
    pub gpu_filter_ms: f64,
    /// The spot check's float64 exact filters, which run beside the GPU wait and the writes
    /// (on a CPU device, on the same cores as the bake).
    pub check: f64,
    /// Encoding and writing the files and the record.
    pub write: f64,
    /// Rendering `preview.png` from the files written, and its checks.
    #[serde(default)]
    pub preview: f64,
    /// The preview's reference (recipe against reference), which runs beside the GPU wait
    /// and the writes.
    #[serde(default)]
    pub preview_reference: f64,
}

impl Stages {
    /// The GPU milliseconds of `timings` split into conversions and filters.
    pub fn gpu(timings: &[crate::gpu::Timing]) -> (f64, f64) {
        let convert = |l: &str| ["convert", "mip", "clamp"].iter().any(|p| l.starts_with(p));
        timings
            .iter()
            .fold((0.0, 0.0), |(c, f), t| match convert(&t.label) {
                true => (c + t.ms, f),
                false => (c, f + t.ms),
            })
    }
}

/// A bake's manifest: its settings and an entry per probe.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Manifest {
    /// What decided the outputs.
    pub settings: Settings,
    /// Their SHA-256 ([`Settings::sha256`]).
    pub settings_sha256: String,
    /// With `--shard`: i/n.
    pub shard: Option<String>,
    /// With `--items`: the range of inputs baked, A-B.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub items: Option<String>,
    /// Every input of the set a shard or range belongs to, in the order shards split it (a
    /// merge names the probes no part has baked).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub inputs: Vec<String>,
    /// The probes, in input order.
    pub probes: Vec<Entry>,
}

/// The record a probe's folder keeps of its bake ([`RECORD`]), so that another run into the
/// same folder — a second shard, a retried job — finds it done.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Record {
    /// The settings' SHA-256.
    pub settings_sha256: String,
    /// The probe's entry.
    pub entry: Entry,
}

/// A probe's record's file name in its folder.
pub const RECORD: &str = "probe.json";

/// SHA-256 of `bytes`, hex.
pub fn sha256(bytes: &[u8]) -> String {
    Sha256::digest(bytes)
        .iter()
        .map(|b| format!("{b:02x}"))
        .collect()
}

/// Writes `files` atomically; their entries, paths relative to `root`.
pub fn write_outputs(root: &Path, files: Vec<(PathBuf, Vec<u8>)>) -> Result<Vec<Output>> {
    let mut outputs = Vec::new();
    for (path, bytes) in files {
        write_atomic(&path, &bytes)?;
        outputs.push(Output {
            file: path
                .strip_prefix(root)
                .unwrap_or(&path)
                .to_string_lossy()
                .replace('\\', "/"),
            bytes: bytes.len() as u64,
            sha256: sha256(&bytes),
        });
    }
    Ok(outputs)
}

/// Takes probe `name`'s lock in `out` (a file lock, which the system drops with a killed
/// process), waiting while another run holds it (`waiting` is called first); the lock, held
/// until the file is dropped, and the seconds waited (None where it was free).
pub fn lock_probe(
    out: &Path,
    name: &str,
    waiting: impl FnOnce(),
) -> Result<(std::fs::File, Option<f64>)> {
    let dir = out.join(name);
    let io = |path: &Path| {
        let path = path.to_path_buf();
        move |source| Error::Io { path, source }
    };
    std::fs::create_dir_all(&dir).map_err(io(&dir))?;
    let path = dir.join(".lock");
    let f = std::fs::OpenOptions::new()
        .create(true)
        .truncate(false)
        .write(true)
        .open(&path)
        .map_err(io(&path))?;
    let waited = match f.try_lock() {
        Ok(()) => None,
        Err(std::fs::TryLockError::WouldBlock) => {
            waiting();
            let t0 = Instant::now();
            f.lock().map_err(io(&path))?;
            Some(t0.elapsed().as_secs_f64())
        }
        Err(std::fs::TryLockError::Error(e)) => return Err(io(&path)(e)),
    };
    Ok((f, waited))
}

/// Probe `name`'s entry when its folder in `out` already holds a bake of `input_sha256` with
/// these settings, its files intact.
pub fn recorded(
    out: &Path,
    name: &str,
    settings_sha256: &str,
    input_sha256: &str,
) -> Option<Entry> {
    let bytes = std::fs::read(out.join(name).join(RECORD)).ok()?;
    let r: Record = serde_json::from_slice(&bytes).ok()?;
    (r.settings_sha256 == settings_sha256
        && r.entry.input_sha256 == input_sha256
        && r.entry.status != "failed"
        && outputs_intact(out, &r.entry))
    .then_some(r.entry)
}

/// Whether every output of `e` under `root` is there with its recorded size and hash.
pub fn outputs_intact(root: &Path, e: &Entry) -> bool {
    !e.outputs.is_empty()
        && e.outputs.iter().all(|o| {
            std::fs::read(root.join(&o.file))
                .is_ok_and(|b| b.len() as u64 == o.bytes && sha256(&b) == o.sha256)
        })
}

/// The manifests in `out` (`manifest*.json`, by name), those that read as manifests.
pub fn read_manifests(out: &Path) -> Vec<Manifest> {
    let Ok(rd) = std::fs::read_dir(out) else {
        return Vec::new();
    };
    let mut paths: Vec<PathBuf> = rd
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| {
            p.file_name()
                .and_then(|n| n.to_str())
                .is_some_and(|n| n.starts_with("manifest") && n.ends_with(".json"))
        })
        .collect();
    paths.sort();
    paths
        .iter()
        .filter_map(|p| std::fs::read(p).ok())
        .filter_map(|b| serde_json::from_slice(&b).ok())
        .collect()
}

/// The manifest's file name: of shard i of n, of inputs a to b, or of the whole set.
pub fn manifest_name(shard: Option<(usize, usize)>, items: Option<(usize, usize)>) -> String {
    match (shard, items) {
        (Some((i, n)), _) => format!("manifest-shard-{i}-of-{n}.json"),
        (None, Some((a, b))) => format!("manifest-items-{a}-{b}.json"),
        (None, None) => "manifest.json".into(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bake::plan::BakeSettings;
    use crate::io::ktx2::Ktx2Format;

    fn temp(name: &str) -> PathBuf {
        let d =
            std::env::temp_dir().join(format!("envlight-manifest-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(&d).unwrap();
        d
    }

    fn entry(input_sha256: &str, outputs: Vec<Output>) -> Entry {
        Entry {
            outputs,
            ..Entry::new("in/p.hdr".into(), input_sha256.into(), "baked")
        }
    }

    /// FIPS 180-2's first test vector.
    #[test]
    fn sha256_is_the_standard_one() {
        assert_eq!(
            sha256(b"abc"),
            "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad"
        );
    }

    /// A probe recorded with these settings and this input, its files intact, is found done;
    /// a changed file, other settings, another input, a failed record or none are not.
    #[test]
    fn a_probe_resumes_only_when_everything_it_recorded_holds() {
        let out = temp("resume");
        let dir = out.join("p.hdr");
        std::fs::create_dir_all(&dir).unwrap();
        let files = vec![
            (dir.join("sh.json"), b"{\"order\": 2}".to_vec()),
            (dir.join("specular.ktx2"), vec![7u8; 300]),
        ];
        let outputs = write_outputs(&out, files).unwrap();
        assert_eq!(outputs[1].file, "p.hdr/specular.ktx2");
        assert_eq!(
            (outputs[1].bytes, outputs[1].sha256.clone()),
            (300, sha256(&[7u8; 300]))
        );
        let write_record = |e: Entry| {
            let r = Record {
                settings_sha256: "S".into(),
                entry: e,
            };
            write_atomic(&dir.join(RECORD), &serde_json::to_vec(&r).unwrap()).unwrap();
        };
        assert!(recorded(&out, "p.hdr", "S", "I").is_none(), "no record yet");
        write_record(entry("I", outputs.clone()));
        let found = recorded(&out, "p.hdr", "S", "I").expect("recorded and intact");
        assert_eq!(found.outputs, outputs);
        assert!(recorded(&out, "p.hdr", "other settings", "I").is_none());
        assert!(recorded(&out, "p.hdr", "S", "another input").is_none());
        let mut failed = entry("I", outputs.clone());
        failed.status = "failed".into();
        write_record(failed);
        assert!(recorded(&out, "p.hdr", "S", "I").is_none());
        write_record(entry("I", outputs.clone()));
        let mut bytes = vec![7u8; 300];
        bytes[150] = 8;
        std::fs::write(dir.join("specular.ktx2"), &bytes).unwrap();
        assert!(
            recorded(&out, "p.hdr", "S", "I").is_none(),
            "a changed file"
        );
        std::fs::remove_file(dir.join("specular.ktx2")).unwrap();
        assert!(!outputs_intact(&out, &entry("I", outputs)));
        let _ = std::fs::remove_dir_all(&out);
    }

    /// A second taker of a probe's lock waits until the first lets go, and says how long.
    #[test]
    fn a_held_lock_makes_the_next_run_wait() {
        let out = temp("lock");
        let (first, waited) = lock_probe(&out, "p.hdr", || panic!("the lock was free")).unwrap();
        assert!(waited.is_none());
        let release = std::thread::spawn(move || {
            std::thread::sleep(std::time::Duration::from_millis(200));
            drop(first);
        });
        let mut told = false;
        let (_second, waited) = lock_probe(&out, "p.hdr", || told = true).unwrap();
        release.join().unwrap();
        assert!(told);
        assert!(waited.is_some_and(|s| s >= 0.1), "{waited:?}");
        let _ = std::fs::remove_dir_all(&out);
    }

    /// Manifests are found by name in order, unreadable ones passed over; shards and ranges
    /// name their own.
    #[test]
    fn manifests_are_read_by_name() {
        let out = temp("manifests");
        let plan = BakePlan::new(&BakeSettings::default()).unwrap();
        let settings = Settings::of(&plan);
        let m = |shard: Option<&str>| Manifest {
            settings: settings.clone(),
            settings_sha256: settings.sha256().unwrap(),
            shard: shard.map(String::from),
            items: None,
            inputs: Vec::new(),
            probes: vec![entry("I", Vec::new())],
        };
        for (name, manifest) in [
            (manifest_name(Some((2, 2)), None), m(Some("2/2"))),
            (manifest_name(Some((1, 2)), None), m(Some("1/2"))),
        ] {
            write_atomic(&out.join(name), &serde_json::to_vec(&manifest).unwrap()).unwrap();
        }
        write_atomic(&out.join("manifest-broken.json"), b"{").unwrap();
        write_atomic(&out.join("notes.json"), b"{}").unwrap();
        let read = read_manifests(&out);
        let shards: Vec<_> = read.iter().map(|m| m.shard.clone().unwrap()).collect();
        assert_eq!(shards, ["1/2", "2/2"]);
        assert_eq!(manifest_name(None, Some((3, 9))), "manifest-items-3-9.json");
        assert_eq!(manifest_name(None, None), "manifest.json");
        let _ = std::fs::remove_dir_all(&out);
    }

    /// The settings' hash follows what decides the bytes, and only that.
    #[test]
    fn settings_hash_follows_the_outputs() {
        let hash = |s: BakeSettings| Settings::of(&BakePlan::new(&s).unwrap()).sha256().unwrap();
        let base = hash(BakeSettings::default());
        assert_eq!(base, hash(BakeSettings::default()));
        let half = BakeSettings {
            texels: Some(Ktx2Format::Rgba16f),
            ..Default::default()
        };
        assert_ne!(base, hash(half));
        // The spot check reads the outputs; it does not change them.
        let checked = BakeSettings {
            check: Some(0),
            ..Default::default()
        };
        assert_eq!(base, hash(checked));
    }
}
