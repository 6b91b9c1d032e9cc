//! The tests' own hygiene, checked like `layering.rs` checks imports: no comparison that a NaN
//! passes (`f64::max` folds drop NaN: `NaN.max(x)` is `x`, so a pass writing NaN everywhere
//! would score a worst error of 0) and no wall-clock bound asserted in the command line's
//! tests (times belong to benchmarks). Comparisons go through `tests/common/compare.rs`.

mod common;

use common::compare::{max_of, Errors};
use std::path::{Path, PathBuf};

/// Every `.rs` file under `dir` of the crate, with its text.
fn sources(dir: &str) -> Vec<(PathBuf, String)> {
    let mut out = Vec::new();
    let mut stack = vec![Path::new(env!("CARGO_MANIFEST_DIR")).join(dir)];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() {
                stack.push(p);
            } else if p.extension().is_some_and(|x| x == "rs") {
                out.push((p.clone(), std::fs::read_to_string(&p).unwrap()));
            }
        }
    }
    assert!(!out.is_empty(), "no sources in {dir}");
    out
}

/// The code of a line, its comment removed.
fn code(line: &str) -> &str {
    line.split("//").next().unwrap_or("")
}

/// Whether an assignment `lhs = rhs` folds a place of `lhs` (the whole, or an element of a
/// tuple) into itself with `.max(` or `.min(`: `w = w.max(e)`, `(a, b) = (a.max(x), …)`.
fn folds_into(lhs: &str, rhs: &str) -> bool {
    let ident = |c: char| c.is_alphanumeric() || c == '_';
    let lhs = lhs.trim();
    let places: Vec<&str> = if lhs.starts_with('(') {
        lhs.trim_matches(|c| c == '(' || c == ')')
            .split(',')
            .collect()
    } else {
        vec![lhs]
    };
    places.iter().any(|p| {
        let p = p.trim().trim_start_matches('*');
        !p.is_empty()
            && [".max(", ".min("].iter().any(|m| {
                let pattern = format!("{p}{m}");
                rhs.match_indices(&pattern)
                    .any(|(at, _)| !rhs[..at].ends_with(ident))
            })
    })
}

/// The NaN-blind folds in `text`: (line number, what was found).
fn nan_blind_folds(text: &str) -> Vec<(usize, &'static str)> {
    let mut found = Vec::new();
    for (n, line) in text.lines().enumerate() {
        let c = code(line);
        if ["f64::max", "f32::max", "f64::min", "f32::min"]
            .iter()
            .any(|f| c.contains(f))
        {
            found.push((n + 1, "f64::max / f32::max as a fold"));
        }
        if let Some((lhs, rhs)) = c.split_once(" = ") {
            if !lhs.trim_start().starts_with("let ") && folds_into(lhs, rhs) {
                found.push((n + 1, "x = x.max(…) accumulation"));
            }
        }
        if let Some(rest) = c.split("fold(").nth(1) {
            if rest.contains(".max(") || rest.contains(".min(") {
                found.push((n + 1, "fold(…, |a, b| a.max(b))"));
            }
        }
        for op in ["> worst", ">= worst", "< worst", "<= worst"] {
            if c.contains(op) {
                found.push((n + 1, "a comparison against a running worst"));
            }
        }
    }
    found
}

/// Wall-clock bounds asserted in `text`: an `assert` line naming a time measured by the test.
fn timing_asserts(text: &str) -> Vec<usize> {
    let lines: Vec<&str> = text.lines().map(code).collect();
    let mut found = Vec::new();
    for (n, line) in lines.iter().enumerate() {
        if !line.contains("assert") {
            continue;
        }
        // The assertion's text up to its closing `);`.
        let end = (n..lines.len())
            .find(|&k| lines[k].contains(");"))
            .unwrap_or(n);
        let stmt = lines[n..=end].join(" ");
        if ["elapsed(", "Instant::now", "as_secs"]
            .iter()
            .any(|t| stmt.contains(t))
        {
            found.push(n + 1);
        }
    }
    found
}

/// No test or example folds errors in a way a NaN passes.
#[test]
fn no_comparison_fold_lets_a_nan_pass() {
    let mut bad = Vec::new();
    for dir in ["tests", "examples"] {
        for (path, text) in sources(dir) {
            if path.ends_with("common/compare.rs") || path.ends_with("honest.rs") {
                continue;
            }
            for (n, what) in nan_blind_folds(&text) {
                bad.push(format!("{}:{n}: {what}", path.display()));
            }
        }
    }
    assert!(
        bad.is_empty(),
        "comparisons that a NaN passes (use tests/common/compare.rs):\n{}",
        bad.join("\n")
    );
}

/// The command line's tests assert what a run did, never how long it took.
#[test]
fn no_wall_clock_bound_in_the_command_line_tests() {
    let mut bad = Vec::new();
    for (path, text) in sources("tests") {
        let name = path.file_name().unwrap().to_string_lossy().to_string();
        if !name.starts_with("cli_") {
            continue;
        }
        for n in timing_asserts(&text) {
            bad.push(format!("{}:{n}", path.display()));
        }
    }
    assert!(
        bad.is_empty(),
        "wall-clock bounds asserted:\n{}",
        bad.join("\n")
    );
}

/// The checks above find what they are for (each pattern as the tests wrote it before), and
/// leave alone what is fine: floors in denominators, `let` shadows, comments.
#[test]
fn the_checks_find_each_pattern() {
    let caught = [
        "let worst = v.iter().fold(0.0, f64::max);",
        "let b = x.into_iter().fold(0.0f32, f32::max);",
        "        worst = worst.max(e);",
        "        *worst = worst.max((a - b).abs());",
        "        bins[g] = bins[g].max(e);",
        "        low = low.min(r);",
        "let s = cpu.iter().fold(0.0f64, |a, b| a.max(b.abs()));",
        "        if e > worst {",
        "            (worst_n, worst_p) = (worst_n.max(dn), worst_p.max(dp.max(dt)));",
    ];
    for line in caught {
        assert_eq!(nan_blind_folds(line).len(), 1, "not caught: {line}");
    }
    let fine = [
        "let e = (a - b).abs() / b.abs().max(1e-3);",
        "let du = du.min(1.0 - du);",
        "// worst = worst.max(e) in a comment",
        "assert!(worst <= tol, \"{worst:e}\");",
        "        total = subtotal.max(1.0);",
    ];
    for line in fine {
        assert!(nan_blind_folds(line).is_empty(), "flagged: {line}");
    }
    let timed =
        "let t0 = Instant::now();\nassert!(\n    t0.elapsed().as_secs() < 50,\n    \"slow\"\n);";
    assert_eq!(timing_asserts(timed), vec![2]);
    assert!(timing_asserts("assert!(ok);\neprintln!(\"{:?}\", t0.elapsed());").is_empty());
}

/// The comparison helpers fail on a NaN or an infinity in either operand, and report the
/// worst error with its place.
#[test]
fn the_helpers_refuse_non_finite_operands() {
    let caught = |f: fn()| std::panic::catch_unwind(f).is_err();
    assert!(caught(|| {
        Errors::new().rel(f64::NAN, 1.0, 1.0, 0);
    }));
    assert!(caught(|| {
        Errors::new().rel(1.0, f32::INFINITY, 1.0, 0);
    }));
    assert!(caught(|| {
        Errors::<u32>::new().assert_within(1.0, "nothing");
    }));
    assert!(caught(|| {
        max_of([1.0, f64::NAN, 2.0]);
    }));
    let mut e = Errors::new();
    for (k, (a, b)) in [(1.0, 1.0), (2.5, 2.0), (3.0, 3.0)].into_iter().enumerate() {
        e.rel(a, b, 1.0, k);
    }
    assert_eq!((e.worst(), e.at(), e.count()), (0.25, Some(&1), 3));
    assert!((e.mean() - 0.25 / 3.0).abs() < 1e-15);
}
