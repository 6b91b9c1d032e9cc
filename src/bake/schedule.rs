//! What job schedulers need from a set's bake: the shard a job array's task bakes, read from
//! the scheduler's own variables (`--shard auto`), the items a frame-range scheduler names,
//! and whether a probe failed by its own fault (retrying cannot help) or the system's.

use super::manifest::Failure;
use crate::error::{Error, Result};
use std::path::Path;

/// An [`Error::Invalid`] of a formatted message.
macro_rules! invalid {
    ($($t:tt)*) => {
        Error::Invalid(format!($($t)*))
    };
}

/// Returns an [`Error::Invalid`] of a formatted message.
macro_rules! refuse {
    ($($t:tt)*) => {
        return Err(Error::Invalid(format!($($t)*)))
    };
}

/// (i, n) from "i/n", 1 ≤ i ≤ n.
pub fn parse_shard(s: &str) -> Result<(usize, usize)> {
    let bad = || invalid!("--shard {s}: expected i/n, e.g. 2/8");
    let (i, n) = s.split_once('/').ok_or_else(bad)?;
    let number = |v: &str| {
        v.trim()
            .parse::<usize>()
            .map_err(|e| invalid!("--shard {s}: {e}"))
    };
    let (i, n) = (number(i)?, number(n)?);
    if n == 0 || i == 0 || i > n {
        refuse!("--shard {s}: i must be between 1 and n");
    }
    Ok((i, n))
}

/// Whether `e`, failing the probe read from `input`, is the input's fault: a file envlight
/// could not use ([`Error::BadFile`]), a value it refuses ([`Error::Invalid`]) or the input
/// itself unreadable; anything else (Vulkan, memory, another file) is the system's.
pub fn classify(e: &Error, input: &Path) -> Failure {
    match e.innermost() {
        Error::BadFile { .. } | Error::Invalid(_) => Failure::Input,
        Error::Io { path, .. } if path == input => Failure::Input,
        _ => Failure::System,
    }
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
                .ok_or_else(|| invalid!("--shard {spec}: expected auto or auto/N"))?,
        ),
        None => refuse!("--shard {spec}: expected auto or auto/N"),
    };
    let number = |name: &str| -> Result<Option<usize>> {
        var(name)
            .map(|v| {
                v.trim()
                    .parse::<usize>()
                    .map_err(|_| invalid!("--shard {spec}: {name}={v} is not a count or index"))
            })
            .transpose()
    };
    let Some(&(scheduler, index_var, count_var)) =
        ARRAYS.iter().find(|(_, index, _)| var(index).is_some())
    else {
        let names: Vec<&str> = ARRAYS.iter().map(|a| a.1).collect();
        refuse!(
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
            refuse!("--shard {spec}: {index_var}={raw} is not in the array {min}, {min}+{step}, …");
        }
        ((raw - min) / step, count)
    } else if count_var.is_empty() {
        (raw, None)
    } else {
        (raw, number(count_var)?)
    };
    let n = match (given, count, recorded) {
        (Some(g), Some(c), _) if g != c => {
            refuse!("--shard {spec}: {scheduler}'s array has {c} tasks, not {g}")
        }
        (Some(g), _, _) => g,
        (None, Some(c), _) => c,
        (None, None, Some(r)) => r,
        (None, None, None) => refuse!(
            "--shard {spec}: {scheduler} gives the index ({index_var}) but not the task \
             count; give it as --shard auto/N"
        ),
    };
    if position >= n {
        refuse!("--shard {spec}: {scheduler}'s task {position} (from 0) is not among {n} shards");
    }
    Ok((position + 1, n))
}

/// The inputs `--items A-B` names, for frame-range schedulers (Deadline's
/// `<STARTFRAME>-<ENDFRAME>`, OpenCue's `#FRAME_START#-#FRAME_END#`, an OpenJD range): 1-based
/// and inclusive in the sorted list of `count` inputs; `A` alone is `A-A`.
pub fn parse_items(spec: &str, count: usize) -> Result<(usize, usize)> {
    let bad = || invalid!("--items {spec}: expected A-B, 1-based and inclusive, e.g. 1-10");
    let (a, b) = spec.split_once('-').unwrap_or((spec, spec));
    let a: usize = a.trim().parse().map_err(|_| bad())?;
    let b: usize = b.trim().parse().map_err(|_| bad())?;
    if a == 0 || b < a {
        return Err(bad());
    }
    if b > count {
        refuse!("--items {spec}: there are only {count} inputs");
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
    fn shards_are_read_and_bounded() {
        assert_eq!(parse_shard("2/8").unwrap(), (2, 8));
        assert_eq!(parse_shard(" 1 / 1 ").unwrap(), (1, 1));
        for bad in ["0/3", "4/3", "1/0", "x/3", "3"] {
            let e = parse_shard(bad).unwrap_err().to_string();
            assert!(e.starts_with(&format!("--shard {bad}: ")), "{e}");
        }
    }

    #[test]
    fn failures_are_told_apart() {
        let input = Path::new("/data/sky.hdr");
        let bad = Error::bad_file(input, "truncated");
        assert_eq!(classify(&bad, input), Failure::Input);
        let unreadable = Error::Io {
            path: input.into(),
            source: std::io::Error::other("denied"),
        };
        assert_eq!(
            classify(&unreadable.context("reading"), input),
            Failure::Input
        );
        let write = Error::Io {
            path: "/out/sky.hdr/specular.ktx2".into(),
            source: std::io::Error::other("no space left"),
        };
        assert_eq!(
            classify(&write.context("/data/sky.hdr"), input),
            Failure::System
        );
        let gpu = Error::NoDevice("lost".into());
        assert_eq!(classify(&gpu, input), Failure::System);
    }
}
