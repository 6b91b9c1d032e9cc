//! The loop of a set's bake ([`super::set::SetBake::run`]): a reader thread reads, hashes and
//! decodes the next probe while the GPU bakes one and the previous one's files are written
//! and checked.

use super::files::{probe_files, Clamps};
use super::gallery::write_gallery;
use super::manifest::{
    lock_probe, outputs_intact, recorded, sha256, write_outputs, Entry, Output, Record, Reduced,
    Stages, RECORD,
};
use super::manifest::{manifest_name, Manifest};
use super::output::SeparateLights;
use super::plan::BakePlan;
use super::preview::reference::ReferenceView;
use super::preview::{preview, reference_view, PreviewCubes, Source, PREVIEW_FILE};
use super::schedule::classify;
use super::set::{input_name, write_dfg, write_json, Part, Progress, SetBake, Written};
use super::{Baked, Baker, PendingBake, SpotCheckPlan};
use crate::error::{Error, Result};
use crate::gpu::{total_ms, Context};
use crate::io::LoadOptions;
use crate::math::convert::{reduce_to_fit, Reduction};
use crate::{EnvMap, Mapping};
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Texels past which a probe is large (4 Mi, a 2896 × 1448 lat-long: 64 MiB of RGBA32F): its
/// bake overlaps no other probe's, and the next probe is read only once it is finished, so
/// that a set of large maps holds one at a time.
const LARGE_TEXELS: usize = 1 << 22;

/// A probe as the reader thread hands it over.
enum Prepared {
    /// Unchanged since a previous run: its entry, marked skipped.
    Skip(Box<Entry>),
    /// To bake: the decoded map, or why it could not be read.
    Bake {
        path: PathBuf,
        input: String,
        input_sha256: String,
        map: Result<EnvMap>,
        /// Seconds spent reading, hashing and decoding it.
        read_s: f64,
    },
}

/// A probe whose bake is on the GPU.
struct InGpu {
    path: PathBuf,
    name: String,
    input: String,
    input_sha256: String,
    /// The source, for the spot check and the preview's reference.
    map: Option<EnvMap>,
    /// Seconds spent reading, hashing and decoding it.
    read_s: f64,
    pending: PendingBake,
    /// With separate lights: the lights the cubes leave out.
    lights: Option<SeparateLights>,
    /// The probe's lock, held until its files and record are written.
    _lock: std::fs::File,
    /// Seconds spent waiting for the lock (None: it was free).
    lock_wait: Option<f64>,
    /// How the source was reduced to fit, where it was.
    reduced: Option<Reduced>,
}

/// A probe the main loop took up: on the GPU, or done (skipped or failed) with its entry.
enum Started {
    Gpu(Box<InGpu>),
    Done(Box<Entry>),
}

/// One run's fixed parts, shared by its probes.
pub(super) struct Run<'a> {
    pub(super) job: &'a SetBake<'a>,
    pub(super) baker: &'a Baker,
    pub(super) force: bool,
    /// The largest side a source is baked at: a lat-long's, an angular's or a paraboloid's
    /// (the device's largest 2D image), a cube's face (its largest cube), either no more
    /// than the plan's `max_source_side`.
    pub(super) max_side: (u32, u32),
    pub(super) progress: &'a dyn Progress,
}

/// `map` reduced to fit `limit` texels a side ([`reduce_to_fit`]), and how; as it is where
/// it fits.
fn fit(map: EnvMap, limit: u32) -> (EnvMap, Option<Reduced>) {
    match reduce_to_fit(&map, limit) {
        None => (map, None),
        Some((small, how)) => {
            let r = Reduced {
                from: [map.width, map.height],
                to: [small.width, small.height],
                limit,
                how: match how {
                    Reduction::Blocks(k) => format!("blocks {k}"),
                    Reduction::Resampled => "resampled".into(),
                },
            };
            (small, Some(r))
        }
    }
}

/// Writes one probe's files into `dir` (`files::probe_files`); returns them (paths relative
/// to `root`, with their sizes and hashes) and what clamping took.
fn write_probe(
    root: &Path,
    dir: &Path,
    baked: &Baked,
    plan: &BakePlan,
    lights: Option<&SeparateLights>,
) -> Result<(Vec<Output>, Option<Clamps>)> {
    std::fs::create_dir_all(dir).map_err(|source| Error::Io {
        path: dir.to_path_buf(),
        source,
    })?;
    let made = probe_files(dir, baked, plan, lights)?;
    let outputs = write_outputs(root, made.files)?;
    Ok((outputs, made.clamped))
}

/// An entry of `previous` (or a probe's own record) marked skipped: nothing of it ran now.
fn skipped(e: Entry, lock_wait: Option<f64>) -> Entry {
    Entry {
        status: "skipped".into(),
        lock_wait_seconds: lock_wait,
        stages: None,
        reduced: None,
        ..e
    }
}

impl Run<'_> {
    /// Reads, bakes and writes the job's probes, skipping what its previous manifests (or a
    /// probe's own record) hold done; returns their manifest entries in order.
    pub(super) fn probes(&self) -> Vec<Entry> {
        // A reader thread reads, hashes, checks and decodes the next probe while this one
        // bakes and its files are written. It reads a probe only with a permit, which the
        // baking side hands back as soon as it takes a small probe, but only once it has
        // finished a large one ([`LARGE_TEXELS`]): small probes overlap, a large map is alone
        // in memory (its bake not overlapping another's, and the next not read meanwhile).
        let (tx, rx) = std::sync::mpsc::sync_channel::<Prepared>(1);
        let (permit, permits) = std::sync::mpsc::channel::<()>();
        let _ = permit.send(());
        let job = self.job;
        let force = self.force;
        std::thread::scope(|scope| {
            scope
                .spawn(move || read_probes(&job.mine, &job.previous, &job.out, force, tx, permits));
            self.bake_all(rx, permit)
        })
    }

    /// The entry of a probe that failed, told to the user.
    fn failed(&self, input: String, input_sha256: String, e: Error, read_seconds: f64) -> Entry {
        self.progress.note(&format!("error: {e}"));
        let failure = classify(&e, Path::new(&input));
        Entry {
            error: Some(e.to_string()),
            failure: Some(failure),
            read_seconds,
            ..Entry::new(input, input_sha256, "failed")
        }
    }

    /// The main loop: one probe on the GPU while the previous one is read back, written and
    /// checked, so its upload and recording overlap that work and the GPU does not idle.
    fn bake_all(
        &self,
        rx: std::sync::mpsc::Receiver<Prepared>,
        permit: std::sync::mpsc::Sender<()>,
    ) -> Vec<Entry> {
        // Each probe's seconds: the run's wall time from the previous probe's end to its own,
        // so that they add up to the run's (reading happens alongside, on the reader thread).
        let mut entries = Vec::new();
        let mut mark = Instant::now();
        let mut push = |entries: &mut Vec<Entry>, mut e: Entry| {
            e.seconds = mark.elapsed().as_secs_f64();
            mark = Instant::now();
            self.progress.done(&e);
            entries.push(e);
        };
        let mut in_gpu: Option<Box<InGpu>> = None;
        for job in rx {
            let large =
                matches!(&job, Prepared::Bake { map: Ok(m), .. } if m.texels.len() > LARGE_TEXELS);
            if large {
                if let Some(w) = in_gpu.take() {
                    push(&mut entries, self.finish(w));
                }
            } else {
                let _ = permit.send(());
            }
            let next = match job {
                Prepared::Skip(e) => Started::Done(e),
                Prepared::Bake {
                    path,
                    input,
                    input_sha256,
                    map,
                    read_s,
                } => self.start(path, input, input_sha256, map, read_s),
            };
            // The previous probe finishes while this one runs on the GPU.
            if let Some(w) = in_gpu.take() {
                push(&mut entries, self.finish(w));
            }
            match next {
                Started::Gpu(w) if large => push(&mut entries, self.finish(w)),
                Started::Gpu(w) => in_gpu = Some(w),
                Started::Done(e) => push(&mut entries, *e),
            }
            if large {
                let _ = permit.send(());
            }
        }
        if let Some(w) = in_gpu.take() {
            push(&mut entries, self.finish(w));
        }
        entries
    }

    /// `map` reduced to fit the device ([`fit`]), said where it was.
    fn fitted(&self, name: &str, map: EnvMap) -> (EnvMap, Option<Reduced>) {
        let limit = match map.mapping {
            Mapping::Cube => self.max_side.1,
            _ => self.max_side.0,
        };
        let (map, r) = fit(map, limit);
        if let Some(r) = &r {
            self.progress.note(&format!(
                "{name}: {} × {} reduced to {} × {} ({}; largest side {})",
                r.from[0], r.from[1], r.to[0], r.to[1], r.how, r.limit
            ));
        }
        (map, r)
    }

    /// Locks a probe and submits its bake; or its entry when it is done already (by another
    /// run that held the lock) or could not be read or submitted.
    fn start(
        &self,
        path: PathBuf,
        input: String,
        input_sha256: String,
        map: Result<EnvMap>,
        read_s: f64,
    ) -> Started {
        let (out, plan) = (&self.job.out, self.job.plan);
        let name = path
            .file_name()
            .map(|n| n.to_string_lossy().to_string())
            .unwrap_or_default();
        self.progress.probe(&name);
        let waiting = || {
            self.progress
                .note(&format!("waiting for another bake of {name} to finish"))
        };
        let (lock, lock_wait) = match lock_probe(out, &name, waiting) {
            Ok(l) => l,
            Err(e) => return Started::Done(Box::new(self.failed(input, input_sha256, e, read_s))),
        };
        if !self.force {
            if let Some(e) = recorded(out, &name, &self.job.settings_sha256, &input_sha256) {
                return Started::Done(Box::new(skipped(e, lock_wait)));
            }
        }
        let mut reduced = None;
        let submitted = map.and_then(|map| {
            let (map, r) = self.fitted(&name, map);
            reduced = r;
            // Separate lights: the cubes see the residual, lights.json the lights.
            let (source, lights) = plan.split_lights(map)?;
            let pending = self
                .baker
                .submit(&source, &plan.orientation, &plan.options)?;
            Ok((source, pending, lights))
        });
        match submitted {
            Ok((map, pending, lights)) => Started::Gpu(Box::new(InGpu {
                path,
                name,
                input,
                input_sha256,
                map: Some(map),
                read_s,
                pending,
                lights,
                _lock: lock,
                lock_wait,
                reduced,
            })),
            Err(e) => {
                let e = e.context(path.display().to_string());
                Started::Done(Box::new(self.failed(input, input_sha256, e, read_s)))
            }
        }
    }

    /// Waits for a probe's bake, writes its files and record, checks it; its entry.
    fn finish(&self, w: Box<InGpu>) -> Entry {
        let mut w = *w;
        let plan = self.job.plan;
        let host = w.pending.host_seconds();
        let stages = Stages {
            read: w.read_s,
            lights: host.lights,
            upload: host.upload,
            ..Stages::default()
        };
        // The spot check's exact filters and the preview's reference need the source alone:
        // they run while the GPU bakes.
        let map = w.map.take();
        let separated = w.lights.clone();
        std::thread::scope(|s| {
            let checking = map.as_ref().filter(|_| plan.check > 0).map(|map| {
                s.spawn(move || {
                    let t = Instant::now();
                    let o = &plan.options;
                    let c = SpotCheckPlan::new(map, &plan.orientation, o, plan.check);
                    (c, t.elapsed().as_secs_f64())
                })
            });
            let referencing = map.as_ref().filter(|_| plan.preview).map(|map| {
                let separated = separated.as_ref();
                s.spawn(move || {
                    let t = Instant::now();
                    let v = reference_view(Source { map, separated }, plan);
                    (v, t.elapsed().as_secs_f64())
                })
            });
            self.finish_with(w, stages, checking, referencing)
        })
    }

    /// [`Run::finish`] once the spot check's exact filters are under way (`checking`).
    fn finish_with(
        &self,
        w: InGpu,
        mut stages: Stages,
        checking: Option<std::thread::ScopedJoinHandle<'_, (SpotCheckPlan, f64)>>,
        referencing: Option<std::thread::ScopedJoinHandle<'_, (ReferenceView, f64)>>,
    ) -> Entry {
        let (out, plan) = (&self.job.out, self.job.plan);
        let t0 = Instant::now();
        let result = w
            .pending
            .wait()
            .and_then(|baked| {
                stages.gpu_wait = t0.elapsed().as_secs_f64();
                (stages.gpu_convert_ms, stages.gpu_filter_ms) = Stages::gpu(&baked.timings);
                let dir = out.join(&w.name);
                let t1 = Instant::now();
                let (mut outputs, clamped) =
                    write_probe(out, &dir, &baked, plan, w.lights.as_ref())?;
                stages.write = t1.elapsed().as_secs_f64();
                let t2 = Instant::now();
                let preview = match plan.preview {
                    true => {
                        let intent = PreviewCubes::intent(&baked, plan, w.lights.as_ref());
                        let (reference, seconds) = match referencing {
                            Some(h) => {
                                let (v, s) =
                                    h.join().unwrap_or_else(|p| std::panic::resume_unwind(p));
                                (Some(v), s)
                            }
                            None => (None, 0.0),
                        };
                        stages.preview_reference = seconds;
                        let p = preview(&dir, plan, &intent, reference.as_ref())?;
                        outputs.extend(write_outputs(out, vec![(dir.join(PREVIEW_FILE), p.png)])?);
                        Some(p.check)
                    }
                    false => None,
                };
                stages.preview = t2.elapsed().as_secs_f64();
                let checked = checking.map(|h| {
                    let (c, seconds) = h.join().unwrap_or_else(|p| std::panic::resume_unwind(p));
                    stages.check = seconds;
                    c.compare(&baked)
                });
                let gpu_ms = total_ms(&baked.timings);
                Ok((outputs, gpu_ms, checked, clamped, preview))
            })
            .map_err(|e| e.context(w.path.display().to_string()));
        let entry = match result {
            Ok((outputs, gpu_ms, check, clamped, preview)) => Entry {
                outputs,
                read_seconds: w.read_s,
                gpu_ms,
                check,
                clamped,
                separated: w.lights.as_ref().map(|l| l.share),
                lock_wait_seconds: w.lock_wait,
                stages: Some(stages),
                reduced: w.reduced,
                preview,
                ..Entry::new(w.input, w.input_sha256, "baked")
            },
            Err(e) => return self.failed(w.input, w.input_sha256, e, w.read_s),
        };
        let record = Record {
            settings_sha256: self.job.settings_sha256.clone(),
            entry: entry.clone(),
        };
        match write_json(&out.join(&w.name).join(RECORD), &record) {
            Ok(()) => entry,
            Err(e) => self.failed(entry.input, entry.input_sha256, e, w.read_s),
        }
    }
}

impl SetBake<'_> {
    /// Bakes the part on `ctx` with `baker`: writes the DFG table where the plan asks for it,
    /// then each probe's files and record (skipping, unless `force`, what this folder holds
    /// intact with these settings), then the manifest. A probe that fails is recorded as
    /// failed and the run goes on; the error is the run's own (a table or a manifest that
    /// could not be written).
    pub fn run(
        &self,
        ctx: &Context,
        baker: &Baker,
        force: bool,
        progress: &dyn Progress,
    ) -> Result<Written> {
        if self.plan.dfg {
            write_dfg(baker, self.plan, &self.out)?;
        }
        let info = ctx.info();
        let user = self.plan.max_source_side.unwrap_or(u32::MAX).max(1);
        let run = Run {
            job: self,
            baker,
            force,
            max_side: (
                info.max_image_dimension_2d.min(user),
                info.max_image_dimension_cube.min(user),
            ),
            progress,
        };
        let entries = run.probes();
        let (shard, items) = (self.part.shard(), self.part.items());
        let manifest = Manifest {
            settings: self.settings.clone(),
            settings_sha256: self.settings_sha256.clone(),
            shard: shard.map(|(i, n)| format!("{i}/{n}")),
            items: items.map(|(first, last)| format!("{first}-{last}")),
            inputs: match self.part {
                Part::All => Vec::new(),
                _ => self.names.clone(),
            },
            probes: entries,
        };
        let path = self.out.join(manifest_name(shard, items));
        write_json(&path, &manifest)?;
        write_gallery(&self.out)?;
        Ok(Written { manifest, path })
    }
}

/// The reader thread: each probe of `mine` read, hashed and decoded, or marked skipped when a
/// previous manifest with these settings holds it intact; each read only with a permit from
/// `permits` (see `Run::probes`).
fn read_probes(
    mine: &[PathBuf],
    previous: &[Entry],
    out: &Path,
    force: bool,
    tx: std::sync::mpsc::SyncSender<Prepared>,
    permits: std::sync::mpsc::Receiver<()>,
) {
    for path in mine {
        if permits.recv().is_err() {
            return;
        }
        let t0 = Instant::now();
        let input = input_name(path);
        let bytes = std::fs::read(path);
        let input_sha256 = bytes.as_ref().map(|b| sha256(b)).unwrap_or_default();
        let done = previous
            .iter()
            .find(|e| e.input == input && e.input_sha256 == input_sha256 && outputs_intact(out, e));
        let job = match (done, force) {
            (Some(e), false) => Prepared::Skip(Box::new(skipped(e.clone(), None))),
            _ => {
                let map = bytes
                    .map_err(|source| Error::Io {
                        path: path.clone(),
                        source,
                    })
                    .and_then(|b| crate::io::load_bytes(path, &b, &LoadOptions::default()));
                Prepared::Bake {
                    path: path.clone(),
                    input,
                    input_sha256,
                    map,
                    read_s: t0.elapsed().as_secs_f64(),
                }
            }
        };
        if tx.send(job).is_err() {
            return;
        }
    }
}
