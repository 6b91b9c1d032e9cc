//! The import order error/abi ← math ← io ← gpu ← passes ← scene ← render/bake ← CLI, with no
//! cycle among modules, derived from the paths the sources name; the one place that submits;
//! and one definition of each number GLSL and Rust share.

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

/// A module's path from the crate root: `src/math/footprint.rs` is `math::footprint`,
/// `src/passes/mod.rs` is `passes`.
fn module_of(path: &Path) -> Vec<String> {
    let rel = path
        .strip_prefix(Path::new(env!("CARGO_MANIFEST_DIR")).join("src"))
        .unwrap();
    let mut parts: Vec<String> = rel
        .components()
        .map(|c| c.as_os_str().to_string_lossy().into_owned())
        .collect();
    let last = parts.pop().unwrap();
    let stem = last.trim_end_matches(".rs");
    if !matches!(stem, "mod" | "lib" | "main") {
        parts.push(stem.to_string());
    }
    parts
}

/// The code of a file before its unit tests (`#[cfg(test)]` blocks sit at the end), comments
/// and string literals removed.
fn import_code(text: &str) -> String {
    let body = text.split("#[cfg(test)]").next().unwrap_or("");
    let mut out = String::new();
    for line in code(body) {
        let mut in_str = false;
        for c in line.chars() {
            if c == '"' {
                in_str = !in_str;
            } else if !in_str {
                out.push(c);
            }
        }
        out.push('\n');
    }
    out
}

/// Expands `a::{b, c::{d, e}}` into `a::b`, `a::c::d`, `a::c::e`.
fn expand(tree: &str) -> Vec<String> {
    let tree = tree.trim();
    let Some(open) = tree.find('{') else {
        let t = tree.split(" as ").next().unwrap_or("").trim();
        return vec![t.to_string()];
    };
    let prefix = &tree[..open];
    let inner = &tree[open + 1..tree.rfind('}').unwrap()];
    let (mut parts, mut depth, mut cur) = (Vec::new(), 0, String::new());
    for c in inner.chars() {
        match c {
            '{' => depth += 1,
            '}' => depth -= 1,
            ',' if depth == 0 => {
                parts.push(std::mem::take(&mut cur));
                continue;
            }
            _ => {}
        }
        cur.push(c);
    }
    parts.push(cur);
    parts
        .iter()
        .filter(|p| !p.trim().is_empty())
        .flat_map(|p| expand(p))
        .map(|p| format!("{prefix}{p}"))
        .collect()
}

/// Every path a module names, absolute from the crate's root: `use` trees (with `self::`,
/// `super::` and `envlight::` resolved) and `crate::…` paths in code.
/// `pub use child::…` re-exports are a module's facade, not its dependencies: left out.
fn named_paths(module: &[String], text: &str) -> Vec<Vec<String>> {
    let code = import_code(text);
    let mut trees = Vec::new();
    for stmt in code.split(';') {
        let s = stmt.trim();
        let (public, rest) = match s.strip_prefix("pub use ") {
            Some(r) => (true, r),
            None => (false, s.strip_prefix("use ").unwrap_or("")),
        };
        for p in expand(&rest.split_whitespace().collect::<Vec<_>>().join(" ")) {
            let local = !(p.starts_with("crate::") || p.starts_with("super::"));
            if p.is_empty() || (public && local) {
                continue;
            }
            trees.push(p);
        }
    }
    for root in ["crate::", "super::"] {
        let mut rest = code.as_str();
        while let Some(k) = rest.find(root) {
            let tail = &rest[k..];
            let end = tail
                .find(|c: char| !(c.is_alphanumeric() || c == '_' || c == ':'))
                .unwrap_or(tail.len());
            // `super::super::x` is one path, not two.
            let whole = !rest[..k].ends_with("::");
            if whole && !rest[..k].ends_with("use ") {
                trees.push(tail[..end].trim_end_matches(':').to_string());
            }
            rest = &tail[end..];
        }
    }
    let mut out = Vec::new();
    for t in trees {
        let segs: Vec<&str> = t.split("::").collect();
        let mut abs: Vec<String> = match segs[0] {
            "crate" => vec!["lib".into()],
            "envlight" => vec!["lib".into()],
            "self" => std::iter::once("lib".to_string())
                .chain(module.iter().cloned())
                .collect(),
            "super" => {
                let mut m: Vec<String> = std::iter::once("lib".to_string())
                    .chain(module.iter().cloned())
                    .collect();
                let mut i = 0;
                while segs.get(i) == Some(&"super") {
                    m.pop();
                    i += 1;
                }
                m.extend(segs[i..].iter().map(|s| s.to_string()));
                out.push(m);
                continue;
            }
            _ => continue,
        };
        abs.extend(segs[1..].iter().map(|s| s.to_string()));
        out.push(abs);
    }
    out
}

/// The layer of each top-level module: imports go to the same layer or lower ones.
fn layer(top: &str) -> usize {
    match top {
        "error" | "abi" => 0,
        "math" | "envmap" => 1,
        "io" => 2,
        "gpu" => 3,
        "passes" => 4,
        "scene" => 5,
        "render" | "bake" => 6,
        "bench" => 7,
        "cli" => 8,
        other => panic!("src/{other}: no layer assigned (add it to layer())"),
    }
}

/// The module graph: each module (by its path) to the modules its code names, resolved to the
/// longest module path that exists, through `pub use child::Name` re-exports to the child.
fn module_graph() -> std::collections::BTreeMap<String, std::collections::BTreeSet<String>> {
    use std::collections::{BTreeMap, BTreeSet};
    let files = sources("src", "rs");
    let key = |m: &[String]| m.join("::");
    let modules: BTreeSet<String> = files.iter().map(|(p, _)| key(&module_of(p))).collect();
    // (module, name) → the child it re-exports `name` from.
    let mut reexports: BTreeMap<(String, String), String> = BTreeMap::new();
    for (p, text) in &files {
        let m = module_of(p);
        for stmt in import_code(text).split(';') {
            let Some(r) = stmt.trim().strip_prefix("pub use ") else {
                continue;
            };
            for t in expand(r) {
                let segs: Vec<&str> = t.trim_start_matches("self::").split("::").collect();
                let child = key(&[m.clone(), vec![segs[0].to_string()]].concat());
                if modules.contains(&child) {
                    let name = t.split(" as ").last().unwrap().rsplit("::").next().unwrap();
                    reexports.insert((key(&m), name.trim().to_string()), child);
                }
            }
        }
    }
    let mut graph: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
    for (p, text) in &files {
        let m = module_of(p);
        if m.is_empty() {
            continue; // lib.rs and main.rs: the roots declare and re-export
        }
        let from = key(&m);
        for abs in named_paths(&m, text) {
            if abs.first().map(String::as_str) != Some("lib") {
                continue;
            }
            // `lib::…`: the rest is a module path.
            let segs = &abs[1..];
            let mut to = None;
            for n in (1..=segs.len()).rev() {
                let k = key(&segs[..n]);
                if modules.contains(&k) {
                    let next = segs.get(n).cloned().unwrap_or_default();
                    to = Some(reexports.get(&(k.clone(), next)).cloned().unwrap_or(k));
                    break;
                }
            }
            if let Some(to) = to.filter(|t| *t != from) {
                graph.entry(from.clone()).or_default().insert(to);
            }
        }
    }
    graph
}

/// A cycle through `start` in `graph`, if any.
fn cycle_through(
    graph: &std::collections::BTreeMap<String, std::collections::BTreeSet<String>>,
    start: &str,
) -> Option<Vec<String>> {
    let mut stack = vec![(start.to_string(), vec![start.to_string()])];
    let mut seen = std::collections::BTreeSet::new();
    while let Some((node, path)) = stack.pop() {
        for next in graph.get(&node).into_iter().flatten() {
            if next == start {
                return Some([path.clone(), vec![start.to_string()]].concat());
            }
            if seen.insert(next.clone()) {
                stack.push((next.clone(), [path.clone(), vec![next.clone()]].concat()));
            }
        }
    }
    None
}

/// The layering rules on a module graph: every import goes to its own layer or a lower one,
/// and no module reaches itself again.
fn layering_faults(
    graph: &std::collections::BTreeMap<String, std::collections::BTreeSet<String>>,
) -> Vec<String> {
    let top = |m: &str| m.split("::").next().unwrap_or("").to_string();
    let mut faults = Vec::new();
    for (from, tos) in graph {
        for to in tos {
            let (a, b) = (top(from), top(to));
            if a != b && layer(&b) >= layer(&a) {
                faults.push(format!("{from} imports {to}, of a layer not below its own"));
            }
        }
        if let Some(c) = cycle_through(graph, from) {
            faults.push(format!("cycle: {}", c.join(" → ")));
        }
    }
    faults
}

#[test]
fn imports_go_one_way_without_cycles() {
    let graph = module_graph();
    // The graph is read, not empty: the layers it must hold are in it.
    for (from, to) in [
        ("passes::shade", "gpu"),
        ("render", "passes"),
        ("math::sh", "math::mapping"),
    ] {
        assert!(
            graph
                .get(from)
                .is_some_and(|t| t.iter().any(|m| m.starts_with(to))),
            "the module graph misses {from} → {to}: {graph:?}"
        );
    }
    let faults = layering_faults(&graph);
    assert!(faults.is_empty(), "{}", faults.join("\n"));
}

#[test]
fn a_cycle_or_an_upward_import_is_a_fault() {
    let graph = module_graph();
    let mut cyclic = graph.clone();
    cyclic
        .entry("math::mapping".into())
        .or_default()
        .insert("math::sh".into());
    assert!(
        layering_faults(&cyclic)
            .iter()
            .any(|f| f.starts_with("cycle")),
        "math::sh → math::mapping → math::sh was not found"
    );
    let mut upward = graph.clone();
    upward
        .entry("math::sh".into())
        .or_default()
        .insert("passes::shade".into());
    assert!(layering_faults(&upward)
        .iter()
        .any(|f| f.contains("math::sh imports passes::shade")));
    let mut sideways = graph.clone();
    sideways
        .entry("bake".into())
        .or_default()
        .insert("render".into());
    assert!(layering_faults(&sideways)
        .iter()
        .any(|f| f.contains("bake imports render")));
}

#[test]
fn the_library_keeps_to_std_and_its_own_crates() {
    for (path, text) in sources("src/abi", "rs") {
        assert!(
            code(&text).all(|l| !l.contains("crate::") && !l.contains("ash::")),
            "{}: abi must stay std-only (tools/shaderc includes it by path)",
            path.display()
        );
    }
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

/// The lab (tools/lab) is a user of the library like any other: it depends on it without the
/// test hooks and names none of them, nor the command line's modules; and the program's own
/// sources neither time cmft nor write the lab's performance pages.
#[test]
fn the_lab_uses_the_public_api_and_the_program_keeps_out_of_the_lab() {
    let manifest = std::fs::read_to_string("tools/lab/Cargo.toml").unwrap();
    let dep = manifest
        .lines()
        .find(|l| l.starts_with("envlight = "))
        .expect("the lab depends on envlight");
    assert!(
        dep.contains("default-features = false") && !dep.contains("test-hooks"),
        "tools/lab/Cargo.toml: {dep}"
    );
    let lab = sources("tools/lab/src", "rs");
    assert!(lab.len() >= 10, "the lab's sources: {}", lab.len());
    for (path, text) in lab {
        for name in ["passes::testing", "envlight::hooks", "envlight::cli"] {
            assert!(
                code(&text).all(|l| !l.contains(name)),
                "{}: the lab names {name}",
                path.display()
            );
        }
    }
    for (path, text) in sources("src/cli", "rs") {
        for name in ["ENVLIGHT_CMFT", "bench peers", "page::write_section"] {
            assert!(
                code(&text).all(|l| !l.contains(name)),
                "{}: the program names {name}, which is the lab's",
                path.display()
            );
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
    // Each of these lives in src/abi/ and reaches GLSL through the generated header.
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

#[test]
fn each_shader_file_has_one_main() {
    let shaders: Vec<_> = ["comp", "frag", "vert"]
        .iter()
        .flat_map(|ext| sources("glsl", ext))
        .collect();
    for (path, text) in shaders {
        let mains = code(&text)
            .filter(|l| l.trim_start().starts_with("void main("))
            .count();
        assert_eq!(
            mains,
            1,
            "{}: {mains} main()s (one kernel a file)",
            path.display()
        );
    }
}

/// examples/frame.rs is an engine driving the passes itself: it names nothing of `render`
/// (its scene's choices come from `scene`, its object records from the G-buffer pass).
#[test]
fn the_engine_frame_example_drives_the_passes_without_render() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/frame.rs");
    let text = std::fs::read_to_string(&path).unwrap();
    let named: Vec<&str> = code(&text).filter(|l| l.contains("render::")).collect();
    assert!(
        named.is_empty(),
        "examples/frame.rs names render: {named:?}"
    );
}
