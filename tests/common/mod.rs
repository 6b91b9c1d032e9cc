//! Shared test helpers: a validated context, the clean-teardown check, the probes folder.
#![allow(dead_code)]

pub mod bake;
pub mod compare;
pub mod scenes;
// The probes folder and skip records, shared with the lab's tests (tools/lab/tests).
mod probes;
#[allow(unused_imports)]
pub use probes::{probes, skipped};

/// The tuning constants GLSL and Rust share (`src/abi/parameters.rs`; the layout is private to
/// the library), read by path as tools/shaderc reads the layout: the tests check the library
/// against the same numbers its shaders compile with.
#[path = "../../src/abi/parameters.rs"]
pub mod abi;

use envlight::gpu::{Context, ContextOptions, DeviceSelector};
use std::path::PathBuf;

/// A context with validation on (any message at warning or above fails the test in `finish`).
pub fn ctx() -> Context {
    let mut opts = ContextOptions::new(DeviceSelector::from_env());
    opts.validation = true;
    match Context::new(&opts) {
        Ok(c) => c,
        Err(e) => panic!("no Vulkan context ({e}); run `cargo xtask setup`"),
    }
}

/// Tears the context down and asserts that validation stayed silent throughout, teardown
/// included (the layer reports leaked objects while the device is destroyed), and that every
/// object envlight made is gone. Call after dropping all passes and resources.
pub fn finish(ctx: Context) {
    assert_eq!(ctx.live_objects(), 0, "Vulkan objects leaked");
    let log = ctx.validation_log();
    drop(ctx);
    assert!(
        log.complete(),
        "the context outlived finish(): a clone is still alive"
    );
    let messages = log.messages();
    assert!(
        messages.is_empty(),
        "validation messages:\n{}",
        messages.join("\n")
    );
}

/// Whether the device has `what` (`has`), for a test whose comparison needs it: a test that
/// compares a feature's path with its fallback compares the fallback with itself where the
/// feature is missing. Without it the test is recorded as skipped, and in CI (`CI` set)
/// fails.
pub fn require(has: bool, what: &str) -> bool {
    if !has {
        assert!(
            std::env::var_os("CI").is_none(),
            "CI is set but the device has no {what}: the comparison would run one path twice"
        );
        skipped(&format!(
            "the device has no {what}: the comparison would run one path twice"
        ));
    }
    has
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

/// The float64 conversion of `env` to a dual paraboloid `size` a side, as the GPU converter
/// takes it (exact footprint areas from a lat-long where they serve, else its supersampling):
/// the level 0 the GPU's MIP chains are tested against.
#[allow(dead_code)]
pub fn dp_f64(env: &envlight::EnvMap, size: u32) -> envlight::EnvMap {
    dp_f64_points(env, size, abi::area::PARABOLOID_EDGE_STEPS)
}

/// [`dp_f64`] of a residual, its lights taken out, as a render converts it for its chain
/// (the default's chords per texel edge).
#[allow(dead_code)]
pub fn dp_f64_residual(residual: &envlight::EnvMap, size: u32) -> envlight::EnvMap {
    dp_f64(residual, size)
}

/// [`dp_f64`] with `points` per paraboloid texel edge in the area conversion.
#[allow(dead_code)]
pub fn dp_f64_points(env: &envlight::EnvMap, size: u32, points: u32) -> envlight::EnvMap {
    use envlight::math::Mapping;
    let world_to_file = envlight::Orientation::default().world_to_file();
    // As the converter: exact footprint areas where they serve, else samples.
    if env.mapping == Mapping::LatLong
        && envlight::math::convert::area_serves(
            env.width,
            env.height,
            Mapping::DualParaboloid,
            size,
            world_to_file,
        )
    {
        return envlight::math::convert::latlong_area_points(
            env,
            Mapping::DualParaboloid,
            size,
            world_to_file,
            points,
        );
    }
    let (w, h) = Mapping::DualParaboloid.extent_for_size(size);
    let ss = envlight::passes::Converter::supersampling(
        (env.mapping, env.width, env.height),
        (Mapping::DualParaboloid, w, h),
    );
    dp_f64_with(env, size, ss)
}

/// As [`dp_f64`], with `ss` samples per axis per texel.
#[allow(dead_code)]
pub fn dp_f64_with(env: &envlight::EnvMap, size: u32, ss: u32) -> envlight::EnvMap {
    envlight::math::convert::convert(
        env,
        envlight::math::Mapping::DualParaboloid,
        size,
        envlight::Orientation::default().world_to_file(),
        ss,
    )
}

/// Khronos' `ktx` tool (KTX-Software): `ENVLIGHT_KTX`, else `../shared/peers/ktx/ktx` beside
/// the checkout. `None` (noted as a skip) where neither is there, except in CI (`CI` set),
/// where a missing tool fails the test.
pub fn ktx_tool() -> Option<PathBuf> {
    peer("ENVLIGHT_KTX", "ktx/ktx")
}

/// A peer program: `var` if set, else `../shared/peers/REL` beside the checkout. `None`
/// (noted as a skip) where neither is there, except in CI (`CI` set), where a missing peer
/// fails the test.
fn peer(var: &str, rel: &str) -> Option<PathBuf> {
    let p = match std::env::var_os(var) {
        Some(p) => PathBuf::from(p),
        None => PathBuf::from(env!("CARGO_MANIFEST_DIR"))
            .join("../shared/peers")
            .join(rel),
    };
    if p.is_file() {
        return Some(p);
    }
    assert!(
        std::env::var_os("CI").is_none(),
        "CI is set but {rel} is not at {} (set {var})",
        p.display()
    );
    skipped(&format!("no {rel} at {}", p.display()));
    None
}

/// glTF-IBL-Sampler's wrapper (`ENVLIGHT_IBLSAMPLER`, else the shared peers'; see [`peer`]).
pub fn iblsampler() -> Option<PathBuf> {
    peer("ENVLIGHT_IBLSAMPLER", "iblsampler/iblsampler")
}

/// cmft (`ENVLIGHT_CMFT`, else the shared peers'; see [`peer`]).
pub fn cmft() -> Option<PathBuf> {
    peer("ENVLIGHT_CMFT", "cmft/cmft")
}

/// Runs `ktx validate` on every .ktx2 file under `dir` (any depth) and fails on the first
/// it refuses, with its report. Returns how many it validated (0 where the tool is absent
/// outside CI).
pub fn ktx_validate_all(dir: &std::path::Path) -> usize {
    let Some(ktx) = ktx_tool() else {
        return 0;
    };
    let mut stack = vec![dir.to_path_buf()];
    let mut n = 0;
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() {
                stack.push(p);
            } else if p.extension().is_some_and(|x| x == "ktx2") {
                let o = std::process::Command::new(&ktx)
                    .arg("validate")
                    .arg(&p)
                    .output()
                    .unwrap();
                assert!(
                    o.status.success(),
                    "ktx validate {}:\n{}{}",
                    p.display(),
                    String::from_utf8_lossy(&o.stdout),
                    String::from_utf8_lossy(&o.stderr)
                );
                n += 1;
            }
        }
    }
    n
}

/// Largest |GPU − f64| over all coefficients and channels, relative to |L00| (the largest
/// channel of the float64 L00); a non-finite coefficient on either side fails the test.
pub fn worst_vs_cpu(gpu: &[[f64; 3]], cpu: &[[f64; 3]]) -> f64 {
    assert_eq!(gpu.len(), cpu.len(), "coefficient counts differ");
    let l00 = compare::max_abs(cpu[0]);
    assert!(l00 > 0.0, "L00 of the float64 projection is 0");
    let mut e = compare::Errors::new();
    for (k, (g, c)) in gpu.iter().zip(cpu).enumerate() {
        for ch in 0..3 {
            e.abs(g[ch], c[ch], (k, ch));
        }
    }
    e.worst() / l00
}
