//! A set of probes baked into one folder, as `envlight bake` does and an asset pipeline or a
//! farm's job would: one folder per probe (named as its file) with its files and record, a
//! manifest of the run, resumed runs that skip what is done with these settings, a lock per
//! probe so that runs sharing a folder never bake one probe twice at once, deterministic
//! shards or item ranges of the sorted set, and a merge of the parts' manifests.
//!
//! ```no_run
//! use envlight::bake::plan::{BakePlan, BakeSettings};
//! use envlight::bake::set::{Part, ProbeSet, SetBake, Silent};
//! use envlight::bake::Baker;
//! # fn main() -> envlight::Result<()> {
//! let ctx = envlight::Context::new(&Default::default())?;
//! let plan = BakePlan::new(&BakeSettings::default())?;
//! let set = ProbeSet::new(["probes/".into()])?;
//! let job = SetBake::new(&set, &plan, "baked".as_ref(), Part::All)?;
//! let written = job.run(&ctx, &Baker::new(&ctx)?, false, &Silent)?;
//! println!("{} probes, manifest {}", written.manifest.probes.len(), written.path.display());
//! # Ok(())
//! # }
//! ```

use super::manifest::{read_manifests, Entry, Failure, Manifest, Settings};
use super::plan::BakePlan;
use super::schedule::parse_shard;
use super::Baker;
use crate::error::{Error, Result};
use crate::io::ktx2::{self, Ktx2Format, Ktx2Image};
use crate::io::write_atomic;
use std::path::{Path, PathBuf};

/// The probes of a set: files, sorted, without repeats, no two sharing a file name (each
/// bakes into a folder of its file's name).
#[derive(Clone, Debug, PartialEq)]
pub struct ProbeSet {
    paths: Vec<PathBuf>,
}

impl ProbeSet {
    /// The set of `inputs`: files, and folders' probe files ([`crate::io::probes_in`]).
    /// Refuses an empty set and two inputs with one file name.
    pub fn new(inputs: impl IntoIterator<Item = PathBuf>) -> Result<ProbeSet> {
        let mut paths = Vec::new();
        for p in inputs {
            match p.is_dir() {
                true => paths.extend(crate::io::probes_in(&p)?),
                false => paths.push(p),
            }
        }
        paths.sort();
        paths.dedup();
        if paths.is_empty() {
            return Err(Error::Invalid("no probes among the inputs".into()));
        }
        // Output folders are named by file name: two inputs with one name would overwrite.
        for w in paths.windows(2) {
            if w[0].file_name() == w[1].file_name() {
                return Err(Error::Invalid(format!(
                    "{} and {} share a file name, so their outputs would collide",
                    w[0].display(),
                    w[1].display()
                )));
            }
        }
        Ok(ProbeSet { paths })
    }

    /// The probes, in order.
    pub fn paths(&self) -> &[PathBuf] {
        &self.paths
    }

    /// How many probes.
    pub fn len(&self) -> usize {
        self.paths.len()
    }

    /// Whether the set is empty (never: [`ProbeSet::new`] refuses that).
    pub fn is_empty(&self) -> bool {
        self.paths.is_empty()
    }

    /// The probes' names in manifests (their paths, with forward slashes).
    pub fn names(&self) -> Vec<String> {
        self.paths.iter().map(|p| input_name(p)).collect()
    }

    /// The probes of `part`: shard i of n takes every n-th from the i-th, items a to b the
    /// a-th to the b-th (1-based, inclusive).
    pub fn part(&self, part: Part) -> Vec<PathBuf> {
        match part {
            Part::All => self.paths.clone(),
            Part::Shard { index, count } => self
                .paths
                .iter()
                .enumerate()
                .filter(|(k, _)| k % count == index - 1)
                .map(|(_, p)| p.clone())
                .collect(),
            Part::Items { first, last } => self.paths[first - 1..last].to_vec(),
        }
    }
}

/// An input's name in the manifests.
pub fn input_name(path: &Path) -> String {
    path.to_string_lossy().replace('\\', "/")
}

/// Which probes of a set one run bakes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Part {
    /// Every probe.
    All,
    /// Shard `index` (1-based) of `count`: every `count`-th probe (`schedule::parse_shard`,
    /// `schedule::shard_auto`).
    Shard {
        /// Which shard, from 1.
        index: usize,
        /// Of how many.
        count: usize,
    },
    /// The probes `first` to `last`, 1-based and inclusive (`schedule::parse_items`).
    Items {
        /// The first probe, from 1.
        first: usize,
        /// The last probe.
        last: usize,
    },
}

impl Part {
    pub(super) fn shard(self) -> Option<(usize, usize)> {
        match self {
            Part::Shard { index, count } => Some((index, count)),
            _ => None,
        }
    }

    pub(super) fn items(self) -> Option<(usize, usize)> {
        match self {
            Part::Items { first, last } => Some((first, last)),
            _ => None,
        }
    }
}

/// One run of a set's bake into a folder, checked against what the folder holds.
pub struct SetBake<'a> {
    pub(super) plan: &'a BakePlan,
    pub(super) out: PathBuf,
    pub(super) part: Part,
    pub(super) names: Vec<String>,
    pub(super) mine: Vec<PathBuf>,
    /// Done probes the folder's manifests with these settings record.
    pub(super) previous: Vec<Entry>,
    pub(super) settings: Settings,
    pub(super) settings_sha256: String,
}

/// What a run wrote: its manifest and where.
#[derive(Clone, Debug)]
pub struct Written {
    /// The run's manifest.
    pub manifest: Manifest,
    /// Its file (`manifest.json`, `manifest-shard-I-of-N.json` or `manifest-items-A-B.json`).
    pub path: PathBuf,
}

/// What a run reports as it goes (the command line's progress bar); every call is on the
/// thread that called [`SetBake::run`].
pub trait Progress {
    /// A probe is taken up (its file name).
    fn probe(&self, _name: &str) {}
    /// A probe is done (baked, skipped or failed), with its entry.
    fn done(&self, _entry: &Entry) {}
    /// Something to tell the user: a probe that failed, a wait for another run's lock, a
    /// source reduced to fit the device.
    fn note(&self, _message: &str) {}
}

/// A [`Progress`] that reports nothing.
pub struct Silent;

impl Progress for Silent {}

impl<'a> SetBake<'a> {
    /// `part` of `set` baked with `plan` into `out` (created): refuses a shard of a split
    /// into another count than the folder's shards with these settings, and a part of a set
    /// whose other parts there split another list of inputs.
    pub fn new(set: &ProbeSet, plan: &'a BakePlan, out: &Path, part: Part) -> Result<Self> {
        let settings = Settings::of(plan);
        let settings_sha256 = settings.sha256()?;
        std::fs::create_dir_all(out).map_err(|source| Error::Io {
            path: out.to_path_buf(),
            source,
        })?;
        let manifests: Vec<Manifest> = read_manifests(out)
            .into_iter()
            .filter(|m| m.settings_sha256 == settings_sha256)
            .collect();
        let names = set.names();
        match part {
            Part::All => {}
            Part::Shard { index, count } => {
                for m in &manifests {
                    let Some(shard) = m.shard.as_deref() else {
                        continue;
                    };
                    let Ok((_, n)) = parse_shard(shard) else {
                        continue;
                    };
                    if n != count {
                        return Err(Error::Invalid(format!(
                            "--shard {index}/{count}: the output folder holds shard {shard} of \
                             a split into {n} with these settings; bake every shard with one n \
                             (or into another folder)"
                        )));
                    }
                }
                same_inputs(&format!("--shard {index}/{count}"), &manifests, &names)?;
            }
            Part::Items { first, last } => {
                if first == 0 || last < first || last > names.len() {
                    return Err(Error::Invalid(format!(
                        "--items {first}-{last}: not a range of the {} inputs",
                        names.len()
                    )));
                }
                same_inputs(&format!("--items {first}-{last}"), &manifests, &names)?;
            }
        }
        let previous = manifests
            .into_iter()
            .flat_map(|m| m.probes)
            .filter(|e| e.status != "failed")
            .collect();
        Ok(SetBake {
            plan,
            out: out.to_path_buf(),
            part,
            mine: set.part(part),
            names,
            previous,
            settings,
            settings_sha256,
        })
    }

    /// How many probes this run takes up.
    pub fn len(&self) -> usize {
        self.mine.len()
    }

    /// Whether this run takes up no probe (an empty shard of a small set).
    pub fn is_empty(&self) -> bool {
        self.mine.is_empty()
    }
}

/// Writes `value` as pretty JSON to `path`, atomically.
pub(super) fn write_json(path: &Path, value: &impl serde::Serialize) -> Result<()> {
    let bytes = serde_json::to_vec_pretty(value)
        .map_err(|e| Error::Invalid(format!("{}: {e}", path.display())))?;
    write_atomic(path, &bytes)
}

/// The count of the split the shard manifests in `out` with `plan`'s settings record, if any
/// (what `--shard auto` takes where the scheduler gives no count: `schedule::shard_auto`).
pub fn recorded_split(out: &Path, plan: &BakePlan) -> Result<Option<usize>> {
    let sha = Settings::of(plan).sha256()?;
    Ok(read_manifests(out)
        .iter()
        .filter(|m| m.settings_sha256 == sha)
        .find_map(|m| parse_shard(m.shard.as_deref()?).ok())
        .map(|(_, n)| n))
}

/// Refuses a part (`what`: a shard or a range) of a set whose other parts in the output
/// folder (`recorded`, these settings) split another list of inputs.
fn same_inputs(what: &str, recorded: &[Manifest], inputs: &[String]) -> Result<()> {
    for m in recorded {
        if !m.inputs.is_empty() && m.inputs != inputs {
            let part = match (&m.shard, &m.items) {
                (Some(s), _) => format!("shard {s}"),
                (None, Some(r)) => format!("items {r}"),
                (None, None) => "a bake".to_string(),
            };
            return Err(Error::Invalid(format!(
                "{what}: {part} in the output folder split another list of inputs ({} \
                 against these {}); give every part the same inputs",
                m.inputs.len(),
                inputs.len()
            )));
        }
    }
    Ok(())
}

/// Writes the split-sum table once: `dfg.ktx2` (RGBA32F, A and B in R and G, row √α after
/// row), and for presets that want one `lut.png` (8-bit R = A, G = B, B = 0, row 0 at the
/// smallest roughness: glTF-IBL-Sampler's `outputLUT.png`).
pub fn write_dfg(baker: &Baker, plan: &BakePlan, out: &Path) -> Result<()> {
    let size = plan.options.dfg_size;
    // Kept between runs (`bake::dfg_cache`): it depends on no probe.
    let cache = super::dfg_cache::default_dir();
    let t = baker.dfg_cached(size, true, plan.dfg_axes, cache.as_deref())?;
    let level: Vec<[f32; 4]> = t.iter().map(|v| [v[0], v[1], 0.0, 1.0]).collect();
    let img = Ktx2Image {
        width: size,
        height: size,
        faces: 1,
        layers: 0,
        levels: std::slice::from_ref(&level),
    };
    ktx2::write(&out.join("dfg.ktx2"), &img, Ktx2Format::Rgba32f)?;
    if plan.preset.is_some_and(|p| p.lut()) {
        let byte = |v: f32| (v.clamp(0.0, 1.0) * 255.0).round() as u8;
        let rgb: Vec<u8> = t.iter().flat_map(|v| [byte(v[0]), byte(v[1]), 0]).collect();
        let path = out.join("lut.png");
        let png = image::RgbImage::from_raw(size, size, rgb)
            .ok_or_else(|| Error::Invalid("the LUT's size does not match its texels".into()))?;
        let mut bytes = Vec::new();
        png.write_to(
            &mut std::io::Cursor::new(&mut bytes),
            image::ImageFormat::Png,
        )
        .map_err(|e| Error::bad_file(&path, format!("cannot encode PNG: {e}")))?;
        write_atomic(&path, &bytes)?;
    }
    Ok(())
}

/// The shards' or ranges' manifests of a folder joined: the merged manifest, and what the
/// set still lacks.
#[derive(Clone, Debug)]
pub struct Merged {
    /// The merged manifest (written as `manifest.json`).
    pub manifest: Manifest,
    /// How many part manifests were joined.
    pub parts: usize,
    /// Probes no part baked, with the shard ("shard k") or item ("item k") that holds them.
    pub missing: Vec<(String, String)>,
}

impl Merged {
    /// The failed probes of the merged set.
    pub fn failed(&self) -> impl Iterator<Item = &Entry> {
        self.manifest.probes.iter().filter(|e| e.status == "failed")
    }

    /// Whether the set is whole: nothing missing, nothing failed.
    pub fn complete(&self) -> bool {
        self.missing.is_empty() && self.failed().next().is_none()
    }

    /// The failures of the failed probes (a failure not recorded counts as the system's).
    pub fn failures(&self) -> Vec<Failure> {
        self.failed()
            .map(|e| e.failure.unwrap_or(Failure::System))
            .collect()
    }
}

/// Joins the shard and range manifests in `out` into `out/manifest.json` (one entry a probe,
/// a baked one before a failed one) and says what the set lacks: the probes of shards that
/// left no manifest or did not reach them. Refuses parts of different settings or inputs.
pub fn merge(out: &Path) -> Result<Merged> {
    let parts: Vec<Manifest> = read_manifests(out)
        .into_iter()
        .filter(|m| m.shard.is_some() || m.items.is_some())
        .collect();
    let invalid = |m: String| Err(Error::Invalid(m));
    let Some(first) = parts.first() else {
        return invalid(format!(
            "{}: no shard or range manifests (manifest-shard-I-of-N.json, \
             manifest-items-A-B.json) to merge",
            out.display()
        ));
    };
    // Shards' split: n, and which shards left a manifest.
    let mut n = None;
    let mut seen = Vec::new();
    let mut probes: Vec<Entry> = Vec::new();
    for m in &parts {
        if m.settings_sha256 != first.settings_sha256 {
            return invalid(
                "the parts were baked with different settings; bake them again alike".into(),
            );
        }
        if m.inputs != first.inputs {
            return invalid(
                "the parts split different lists of inputs; bake them again alike".into(),
            );
        }
        if let Some(s) = m.shard.as_deref() {
            let (i, ni) = parse_shard(s)?;
            let n = *n.get_or_insert(ni);
            if ni != n {
                return invalid(format!(
                    "shard {i}/{ni} does not belong to a split into {n}"
                ));
            }
            seen.resize(n, false);
            seen[i - 1] = true;
        }
        probes.extend(m.probes.iter().cloned());
    }
    let absent: Vec<usize> = (1..=seen.len()).filter(|i| !seen[i - 1]).collect();
    if first.inputs.is_empty() {
        // Manifests from before inputs were recorded: a missing shard is all one can say.
        if let (Some(i), Some(n)) = (absent.first(), n) {
            return invalid(format!(
                "shard {i}/{n} has no manifest in {}",
                out.display()
            ));
        }
    }
    // One entry a probe (ranges may overlap), a baked one before a failed one.
    probes.sort_by(|a, b| (&a.input, a.status == "failed").cmp(&(&b.input, b.status == "failed")));
    probes.dedup_by(|later, kept| later.input == kept.input);
    // Probes no part baked, with the shard (k mod n) or item (k + 1) that holds them.
    let baked: std::collections::HashSet<&str> = probes.iter().map(|e| e.input.as_str()).collect();
    let missing: Vec<(String, String)> = first
        .inputs
        .iter()
        .enumerate()
        .filter(|(_, name)| !baked.contains(name.as_str()))
        .map(|(k, name)| {
            let part = match n {
                Some(n) => format!("shard {}", k % n + 1),
                None => format!("item {}", k + 1),
            };
            (name.clone(), part)
        })
        .collect();
    let manifest = Manifest {
        settings: first.settings.clone(),
        settings_sha256: first.settings_sha256.clone(),
        shard: None,
        items: None,
        inputs: first.inputs.clone(),
        probes,
    };
    write_json(&out.join("manifest.json"), &manifest)?;
    super::gallery::write_gallery(out)?;
    Ok(Merged {
        manifest,
        parts: parts.len(),
        missing,
    })
}
