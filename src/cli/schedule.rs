//! What job schedulers need from `envlight bake`: the shard a job array's task bakes, read
//! from the scheduler's own variables (`--shard auto`), and exit codes that tell a bad input
//! (retrying cannot help) from a device or system failure (retry).

use anyhow::{anyhow, bail, Result};
use std::path::Path;

/// Exit code when the only failures were bad inputs (unreadable, truncated, unusable maps):
/// retrying cannot help; the manifest names them (sysexits' EX_DATAERR).
pub const EXIT_BAD_INPUT: i32 = 65;
/// Exit code for a device or system failure (no device, a lost device, out of memory, a
/// write that failed) or a merge that still misses probes: worth retrying (EX_TEMPFAIL).
pub const EXIT_RETRY: i32 = 75;

/// An error that ends the process with its own exit code.
#[derive(Debug)]
pub struct Exit {
    /// The process's exit code.
    pub code: i32,
    /// What to print.
    pub message: String,
}

impl std::fmt::Display for Exit {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.message)
    }
}

impl std::error::Error for Exit {}

pub use crate::bake::manifest::Failure;

/// Whether `e`, failing the probe read from `input`, is the input's fault: a file envlight
/// could not use ([`crate::Error::BadFile`]), a value it refuses ([`crate::Error::Invalid`]) or
/// the input itself unreadable; anything else (Vulkan, memory, another file) is the system's.
pub fn classify(e: &anyhow::Error, input: &Path) -> Failure {
    for cause in e.chain() {
        if let Some(err) = cause.downcast_ref::<crate::Error>() {
            return match err {
                crate::Error::BadFile { .. } | crate::Error::Invalid(_) => Failure::Input,
                crate::Error::Io { path, .. } if path == input => Failure::Input,
                _ => Failure::System,
            };
        }
    }
    Failure::System
}

/// The exit for a run whose failures were `failures` (one per failed probe): none, only bad
/// inputs ([`EXIT_BAD_INPUT`]), or some system failure ([`EXIT_RETRY`]).
pub fn exit_for(failures: &[Failure], message: String) -> Option<Exit> {
    if failures.is_empty() {
        return None;
    }
    let code = match failures.iter().all(|f| *f == Failure::Input) {
        true => EXIT_BAD_INPUT,
        false => EXIT_RETRY,
    };
    Some(Exit { code, message })
}

/// The job array variables `--shard auto` reads, per scheduler: (scheduler, index variable
/// (0-based unless noted), count variable).
const ARRAYS: [(&str, &str, &str); 4] = [
    ("Slurm", "SLURM_ARRAY_TASK_ID", "SLURM_ARRAY_TASK_COUNT"),
    ("Kubernetes", "JOB_COMPLETION_INDEX", ""),
    (
        "AWS Batch",
        "AWS_BATCH_JOB_ARRAY_INDEX",
        "AWS_BATCH_JOB_ARRAY_SIZE",
    ),
    ("Google Batch", "BATCH_TASK_INDEX", "BATCH_TASK_COUNT"),
];

/// The shard (1-based i, n) of `--shard auto` or `--shard auto/N`, from the first job array
/// whose index variable `var` finds: Slurm (SLURM_ARRAY_TASK_ID, counted from
/// SLURM_ARRAY_TASK_MIN in steps of SLURM_ARRAY_TASK_STEP; n from SLURM_ARRAY_TASK_COUNT, or
/// MIN, MAX and STEP), Kubernetes Indexed Jobs (JOB_COMPLETION_INDEX; n given as auto/N, or
/// `recorded`: the split a shard manifest in the output folder records), AWS Batch
/// (AWS_BATCH_JOB_ARRAY_INDEX, AWS_BATCH_JOB_ARRAY_SIZE) and Google Batch (BATCH_TASK_INDEX,
/// BATCH_TASK_COUNT). An N given must agree with the scheduler's count.
pub fn shard_auto(
    spec: &str,
    var: impl Fn(&str) -> Option<String>,
    recorded: Option<usize>,
) -> Result<(usize, usize)> {
    let given = match spec.strip_prefix("auto") {
        Some("") => None,
        Some(rest) => Some(
            rest.strip_prefix('/')
                .and_then(|n| n.trim().parse::<usize>().ok())
                .filter(|&n| n > 0)
                .ok_or_else(|| anyhow!("--shard {spec}: expected auto or auto/N"))?,
        ),
        None => bail!("--shard {spec}: expected auto or auto/N"),
    };
    let number = |name: &str| -> Result<Option<usize>> {
        var(name)
            .map(|v| {
                v.trim()
                    .parse::<usize>()
                    .map_err(|_| anyhow!("--shard {spec}: {name}={v} is not a count or index"))
            })
            .transpose()
    };
    let Some(&(scheduler, index_var, count_var)) =
        ARRAYS.iter().find(|(_, index, _)| var(index).is_some())
    else {
        let names: Vec<&str> = ARRAYS.iter().map(|a| a.1).collect();
        bail!(
            "--shard {spec}: no job array index in the environment ({}); give --shard I/N",
            names.join(", ")
        );
    };
    let raw = number(index_var)?.unwrap_or(0);
    let (position, count) = if scheduler == "Slurm" {
        let min = number("SLURM_ARRAY_TASK_MIN")?.unwrap_or(0);
        let step = number("SLURM_ARRAY_TASK_STEP")?.unwrap_or(1).max(1);
        let from_range = number("SLURM_ARRAY_TASK_MAX")?
            .filter(|&max| max >= min)
            .map(|max| (max - min) / step + 1);
        let count = number(count_var)?.or(from_range);
        if raw < min || !(raw - min).is_multiple_of(step) {
            bail!("--shard {spec}: {index_var}={raw} is not in the array {min}, {min}+{step}, …");
        }
        ((raw - min) / step, count)
    } else if count_var.is_empty() {
        (raw, None)
    } else {
        (raw, number(count_var)?)
    };
    let n = match (given, count, recorded) {
        (Some(g), Some(c), _) if g != c => {
            bail!("--shard {spec}: {scheduler}'s array has {c} tasks, not {g}")
        }
        (Some(g), _, _) => g,
        (None, Some(c), _) => c,
        (None, None, Some(r)) => r,
        (None, None, None) => bail!(
            "--shard {spec}: {scheduler} gives the index ({index_var}) but not the task \
             count; give it as --shard auto/N"
        ),
    };
    if position >= n {
        bail!("--shard {spec}: {scheduler}'s task {position} (from 0) is not among {n} shards");
    }
    Ok((position + 1, n))
}

/// The inputs `--items A-B` names, for frame-range schedulers (Deadline's
/// `<STARTFRAME>-<ENDFRAME>`, OpenCue's `#FRAME_START#-#FRAME_END#`, an OpenJD range): 1-based
/// and inclusive in the sorted list of `count` inputs; `A` alone is `A-A`.
pub fn parse_items(spec: &str, count: usize) -> Result<(usize, usize)> {
    let bad = || anyhow!("--items {spec}: expected A-B, 1-based and inclusive, e.g. 1-10");
    let (a, b) = spec.split_once('-').unwrap_or((spec, spec));
    let a: usize = a.trim().parse().map_err(|_| bad())?;
    let b: usize = b.trim().parse().map_err(|_| bad())?;
    if a == 0 || b < a {
        return Err(bad());
    }
    if b > count {
        bail!("--items {spec}: there are only {count} inputs");
    }
    Ok((a, b))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn env<'a>(pairs: &'a [(&'a str, &'a str)]) -> impl Fn(&str) -> Option<String> + 'a {
        move |k| pairs.iter().find(|p| p.0 == k).map(|p| p.1.to_string())
    }

    #[test]
    fn each_scheduler_names_its_shard() {
        let slurm = [
            ("SLURM_ARRAY_TASK_ID", "3"),
            ("SLURM_ARRAY_TASK_COUNT", "4"),
        ];
        assert_eq!(shard_auto("auto", env(&slurm), None).unwrap(), (4, 4));
        // An array 1-4 (sbatch --array=1-4): MIN 1.
        let slurm1 = [
            ("SLURM_ARRAY_TASK_ID", "1"),
            ("SLURM_ARRAY_TASK_MIN", "1"),
            ("SLURM_ARRAY_TASK_MAX", "4"),
        ];
        assert_eq!(shard_auto("auto", env(&slurm1), None).unwrap(), (1, 4));
        // --array=0-14:5 → tasks 0, 5, 10.
        let stepped = [
            ("SLURM_ARRAY_TASK_ID", "10"),
            ("SLURM_ARRAY_TASK_MIN", "0"),
            ("SLURM_ARRAY_TASK_MAX", "10"),
            ("SLURM_ARRAY_TASK_STEP", "5"),
        ];
        assert_eq!(shard_auto("auto", env(&stepped), None).unwrap(), (3, 3));
        let k8s = [("JOB_COMPLETION_INDEX", "2")];
        assert_eq!(shard_auto("auto/5", env(&k8s), None).unwrap(), (3, 5));
        assert_eq!(shard_auto("auto", env(&k8s), Some(6)).unwrap(), (3, 6));
        let aws = [
            ("AWS_BATCH_JOB_ARRAY_INDEX", "0"),
            ("AWS_BATCH_JOB_ARRAY_SIZE", "10"),
        ];
        assert_eq!(shard_auto("auto", env(&aws), None).unwrap(), (1, 10));
        let google = [("BATCH_TASK_INDEX", "7"), ("BATCH_TASK_COUNT", "8")];
        assert_eq!(shard_auto("auto/8", env(&google), None).unwrap(), (8, 8));
    }

    #[test]
    fn what_cannot_name_a_shard_is_refused() {
        let msg = |spec: &str, pairs: &[(&str, &str)], rec| {
            format!("{:#}", shard_auto(spec, env(pairs), rec).unwrap_err())
        };
        assert!(msg("auto", &[], None).contains("no job array index"));
        assert!(msg("auto", &[("JOB_COMPLETION_INDEX", "1")], None).contains("auto/N"));
        assert!(msg(
            "auto/3",
            &[("BATCH_TASK_INDEX", "0"), ("BATCH_TASK_COUNT", "4")],
            None
        )
        .contains("has 4 tasks, not 3"));
        assert!(msg("auto/2", &[("JOB_COMPLETION_INDEX", "2")], None).contains("not among 2"));
        assert!(msg("auto", &[("AWS_BATCH_JOB_ARRAY_INDEX", "x")], None).contains("not a count"));
        assert!(msg("auto/0", &[], None).contains("expected auto"));
        let off_step = [
            ("SLURM_ARRAY_TASK_ID", "3"),
            ("SLURM_ARRAY_TASK_MIN", "0"),
            ("SLURM_ARRAY_TASK_STEP", "2"),
            ("SLURM_ARRAY_TASK_COUNT", "4"),
        ];
        assert!(msg("auto", &off_step, None).contains("not in the array"));
    }

    #[test]
    fn item_ranges_are_read_and_bounded() {
        assert_eq!(parse_items("1-10", 12).unwrap(), (1, 10));
        assert_eq!(parse_items(" 4 ", 12).unwrap(), (4, 4));
        assert_eq!(parse_items("11-12", 12).unwrap(), (11, 12));
        let msg = |s: &str| format!("{:#}", parse_items(s, 12).unwrap_err());
        assert!(msg("12-13").contains("only 12 inputs"));
        assert!(msg("0-3").contains("expected A-B"));
        assert!(msg("5-3").contains("expected A-B"));
        assert!(msg("a-b").contains("expected A-B"));
    }

    #[test]
    fn failures_are_told_apart() {
        let input = Path::new("/data/sky.hdr");
        let bad: anyhow::Error = crate::Error::bad_file(input, "truncated").into();
        assert_eq!(classify(&bad, input), Failure::Input);
        let unreadable: anyhow::Error = crate::Error::Io {
            path: input.into(),
            source: std::io::Error::other("denied"),
        }
        .into();
        assert_eq!(
            classify(&unreadable.context("reading"), input),
            Failure::Input
        );
        let write: anyhow::Error = crate::Error::Io {
            path: "/out/sky.hdr/specular.ktx2".into(),
            source: std::io::Error::other("no space left"),
        }
        .into();
        assert_eq!(classify(&write, input), Failure::System);
        let gpu: anyhow::Error = crate::Error::NoDevice("lost".into()).into();
        assert_eq!(classify(&gpu, input), Failure::System);
        assert_eq!(classify(&anyhow!("anything else"), input), Failure::System);
        use Failure::{Input, System};
        assert!(exit_for(&[], String::new()).is_none());
        assert_eq!(
            exit_for(&[Input, Input], String::new()).unwrap().code,
            EXIT_BAD_INPUT
        );
        assert_eq!(
            exit_for(&[Input, System], String::new()).unwrap().code,
            EXIT_RETRY
        );
    }
}
