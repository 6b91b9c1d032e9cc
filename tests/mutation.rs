//! The mutation matrix: each of the fifteen passes corrupts its own output three ways — one
//! NaN, every value scaled by 1 + 10 × its twin test's bound, the output mirrored
//! (`passes::testing::poison`, feature `test-hooks`) — and its twin test's comparisons, the
//! ones `tests/<pass>.rs` runs, must fail on every one. A comparison that a NaN or a mirrored
//! map passes would show here as a hole in the printed matrix.

mod common;

#[path = "twins/brute.rs"]
mod brute;
#[path = "twins/convert.rs"]
mod convert;
#[path = "twins/exact.rs"]
mod exact;
#[path = "twins/extract.rs"]
mod extract;
#[path = "twins/gbuffer.rs"]
mod gbuffer;
#[path = "twins/lights.rs"]
mod lights;
#[path = "twins/map.rs"]
mod map;
#[path = "twins/mc.rs"]
mod mc;
#[path = "twins/mip.rs"]
mod mip;
#[path = "twins/sh_brdf.rs"]
mod sh_brdf;
#[path = "twins/sh_eval.rs"]
mod sh_eval;
#[path = "twins/sh_pack.rs"]
mod sh_pack;
#[path = "twins/sh_project.rs"]
mod sh_project;
#[path = "twins/shade.rs"]
mod shade;
#[path = "twins/split_sum.rs"]
mod split_sum;

use envlight::gpu::Context;
use envlight::passes::testing::poison::{self, Corruption, PassId, Poison};
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::sync::{Arc, Mutex};

/// A pass, its twin test and that test's bound.
type Row = (PassId, fn(&Context), f64);

/// Each pass with its twin test and that test's bound.
fn rows() -> [Row; 16] {
    [
        (PassId::Brute, brute::check, brute::BOUND),
        (PassId::Convert, convert::check, convert::BOUND),
        (PassId::Convert, convert::check_split, convert::BOUND),
        (PassId::Exact, exact::check, exact::BOUND),
        (PassId::Extract, extract::check, extract::BOUND),
        (PassId::GBuffer, gbuffer::check, gbuffer::BOUND),
        (PassId::Lights, lights::check, lights::BOUND),
        (PassId::Map, map::check, map::BOUND),
        (PassId::Mc, mc::check, mc::BOUND),
        (PassId::Mip, mip::check, mip::BOUND),
        (PassId::ShBrdf, sh_brdf::check, sh_brdf::BOUND),
        (PassId::ShEval, sh_eval::check, sh_eval::BOUND),
        (PassId::ShPack, sh_pack::check, sh_pack::BOUND),
        (PassId::ShProject, sh_project::check, sh_project::BOUND),
        (PassId::Shade, shade::check, shade::BOUND),
        (PassId::SplitSum, split_sum::check, split_sum::BOUND),
    ]
}

/// The first line of what a caught check panicked with, or None where it passed.
fn run_poisoned(
    ctx: &Context,
    poison: Poison,
    check: fn(&Context),
    said: &Mutex<String>,
) -> Option<String> {
    poison::set(ctx, Some(poison));
    let r = catch_unwind(AssertUnwindSafe(|| check(ctx)));
    poison::set(ctx, None);
    r.err().map(|_| {
        let s = said.lock().unwrap();
        s.lines().next().unwrap_or("").chars().take(110).collect()
    })
}

#[test]
fn every_pass_fails_its_twin_test_on_each_corruption() {
    let ctx = common::ctx();
    // The checks' panics are the result here: keep their messages for the matrix.
    let said = Arc::new(Mutex::new(String::new()));
    let keep = said.clone();
    let default_hook = std::panic::take_hook();
    std::panic::set_hook(Box::new(move |info| {
        let msg = info
            .payload()
            .downcast_ref::<String>()
            .cloned()
            .or_else(|| info.payload().downcast_ref::<&str>().map(|s| s.to_string()))
            .unwrap_or_default();
        let at = info
            .location()
            .map(|l| format!("{}:{}", l.file(), l.line()));
        *keep.lock().unwrap() = format!("{} ({})", msg.replace('\n', " "), at.unwrap_or_default());
    }));
    let mut matrix = Vec::new();
    let mut missed = Vec::new();
    for (pass, check, bound) in rows() {
        let scale = (1.0 + 10.0 * bound) as f32;
        for corruption in [
            Corruption::Nan,
            Corruption::Scale(scale),
            Corruption::Mirror,
        ] {
            let poison = Poison { pass, corruption };
            let caught = run_poisoned(&ctx, poison, check, &said);
            match &caught {
                Some(msg) if !msg.contains("the device has no") => {}
                _ => missed.push(format!("{} {}", pass.name(), corruption.name())),
            }
            matrix.push(format!(
                "| {} | {}{} | {} |",
                pass.name(),
                corruption.name(),
                match corruption {
                    Corruption::Scale(f) => format!(" ×{f}"),
                    _ => String::new(),
                },
                caught
                    .as_deref()
                    .map_or("**passed**".to_string(), |m| format!("caught: {m}"))
            ));
        }
    }
    std::panic::set_hook(default_hook);
    println!("| pass | corruption | its twin test |\n|---|---|---|");
    for row in &matrix {
        println!("{row}");
    }
    assert!(
        missed.is_empty(),
        "corruptions the twin tests let through: {missed:?}"
    );
    common::finish(ctx);
}
