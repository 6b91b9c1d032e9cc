//! The real probes folder, and the record of a test that skipped its work: shared by the
//! library's tests (`common`) and the lab's (tools/lab/tests include this file by path).
#![allow(dead_code)]

use std::path::PathBuf;

/// The real probes folder from ENVLIGHT_PROBES, or None when it is unset. When it is set it
/// must exist, and in CI (`CI` set, as `.ci/run` does) it must be set: there the probe tests
/// never skip. A skip is noted on stderr and in the file `ENVLIGHT_SKIP_LOG` names, which
/// `cargo xtask test` prints in its summary.
pub fn probes() -> Option<PathBuf> {
    match std::env::var_os("ENVLIGHT_PROBES") {
        Some(p) => {
            let p = PathBuf::from(p);
            assert!(
                p.is_dir(),
                "ENVLIGHT_PROBES={} is not a folder",
                p.display()
            );
            Some(p)
        }
        None => {
            assert!(
                std::env::var_os("CI").is_none(),
                "CI is set but ENVLIGHT_PROBES is not: the tests on real probes must run in CI \
                 (.ci/run sets it to ../shared/probes)"
            );
            skipped("ENVLIGHT_PROBES is unset: the tests on real probes did not run");
            None
        }
    }
}

/// Records that the current test skipped its work, and why.
pub fn skipped(why: &str) {
    let test = std::thread::current()
        .name()
        .unwrap_or("(unnamed test)")
        .to_string();
    eprintln!("SKIPPED {test}: {why}");
    if let Some(log) = std::env::var_os("ENVLIGHT_SKIP_LOG") {
        use std::io::Write;
        if let Ok(mut f) = std::fs::OpenOptions::new()
            .create(true)
            .append(true)
            .open(log)
        {
            let _ = writeln!(f, "{test}: {why}");
        }
    }
}
