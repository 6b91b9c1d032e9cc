//! The import order abi ← math ← gpu ← passes ← scene/render ← CLI, the one place that
//! submits, and one definition of each number GLSL and Rust share, checked on the sources.

use std::path::{Path, PathBuf};

fn sources(dir: &str, ext: &str) -> Vec<(PathBuf, String)> {
    let mut out = Vec::new();
    let mut stack = vec![Path::new(env!("CARGO_MANIFEST_DIR")).join(dir)];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() {
                stack.push(p);
            } else if p.extension().is_some_and(|x| x == ext) {
                let text = std::fs::read_to_string(&p).unwrap();
                out.push((p, text));
            }
        }
    }
    assert!(!out.is_empty(), "no sources in {dir}");
    out
}

/// Code lines only: comments and doc comments may name any layer.
fn code(text: &str) -> impl Iterator<Item = &str> {
    text.lines()
        .map(|l| l.split("//").next().unwrap_or(""))
        .filter(|l| !l.trim().is_empty())
}

#[test]
fn imports_go_one_way() {
    let rules: [(&str, &[&str]); 3] = [
        (
            "src/math",
            &[
                "crate::gpu",
                "crate::passes",
                "crate::render",
                "crate::scene",
            ],
        ),
        (
            "src/gpu",
            &[
                "crate::math",
                "crate::passes",
                "crate::render",
                "crate::scene",
            ],
        ),
        ("src/passes", &["crate::render", "crate::scene"]),
    ];
    for (dir, banned) in rules {
        for (path, text) in sources(dir, "rs") {
            for line in code(&text) {
                for b in banned {
                    assert!(!line.contains(b), "{}: imports {b}: {line}", path.display());
                }
            }
        }
    }
    let abi =
        std::fs::read_to_string(Path::new(env!("CARGO_MANIFEST_DIR")).join("src/abi.rs")).unwrap();
    assert!(
        code(&abi).all(|l| !l.contains("crate::") && !l.contains("ash::")),
        "src/abi.rs must stay std-only"
    );
    for (path, text) in sources("src", "rs") {
        let cli = path.components().any(|c| c.as_os_str() == "cli") || path.ends_with("main.rs");
        if !cli {
            for dep in ["clap::", "indicatif::", "anyhow::"] {
                assert!(
                    code(&text).all(|l| !l.contains(dep)),
                    "{}: the library uses {dep}",
                    path.display()
                );
            }
        }
    }
}

#[test]
fn only_the_runner_submits() {
    for (path, text) in sources("src", "rs") {
        let runner = path.ends_with("gpu/context.rs");
        for line in code(&text) {
            for call in ["queue_submit", "wait_for_fences", "device_wait_idle"] {
                assert!(
                    runner || !line.contains(call),
                    "{}: {call} outside the runner",
                    path.display()
                );
            }
        }
    }
}

#[test]
fn shared_numbers_are_not_literal_in_glsl() {
    // Each of these lives in src/abi.rs and reaches GLSL through the generated header.
    let literals = ["0.2126", "0.7152", "1.25", "0.999", "1e-4", "0.2886"];
    for (path, text) in sources("glsl", "glsl")
        .into_iter()
        .chain(sources("glsl", "comp"))
        .chain(sources("glsl", "frag"))
    {
        if path.ends_with("generated.glsl") || path.ends_with("busy.comp") {
            continue;
        }
        for line in code(&text) {
            for lit in literals {
                assert!(
                    !line.contains(lit),
                    "{}: literal {lit} (use the generated constant): {line}",
                    path.display()
                );
            }
        }
    }
}
