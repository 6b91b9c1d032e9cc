//! Shared test helpers: a validated context, the clean-teardown check, the probes folder.
#![allow(dead_code)]

pub mod scenes;

use envlight::gpu::{Context, ContextOptions, DeviceSelector};
use std::path::PathBuf;

/// A context with validation on (any message at warning or above fails the test in `finish`).
pub fn ctx() -> Context {
    match Context::new(&ContextOptions {
        validation: true,
        device: DeviceSelector::from_env(),
    }) {
        Ok(c) => c,
        Err(e) => panic!("no Vulkan context ({e}); run `cargo xtask setup`"),
    }
}

/// Asserts that validation stayed silent and every object envlight made is gone. Call after
/// dropping all passes and resources.
pub fn finish(ctx: Context) {
    let messages = ctx.validation_messages();
    assert!(
        messages.is_empty(),
        "validation messages:\n{}",
        messages.join("\n")
    );
    assert_eq!(ctx.live_objects(), 0, "Vulkan objects leaked");
}

/// The real probes folder from ENVLIGHT_PROBES, or None (and a note) when it is unset. When it
/// is set, it must exist: tests never skip then.
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
            eprintln!("ENVLIGHT_PROBES is unset: skipping the tests on real probes");
            None
        }
    }
}

/// Writes actual and expected maps beside each other under target/test-output for a person to
/// compare when a test fails.
pub fn dump_pair(name: &str, actual: &envlight::EnvMap, expected: &envlight::EnvMap) {
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("test-output");
    let _ = std::fs::create_dir_all(&dir);
    let _ = envlight::io::save_exr(actual, dir.join(format!("{name}_actual.exr")));
    let _ = envlight::io::save_exr(expected, dir.join(format!("{name}_expected.exr")));
    eprintln!("wrote {}/{name}_{{actual,expected}}.exr", dir.display());
}
