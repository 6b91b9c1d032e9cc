//! Replays every committed fuzz input (tools/fuzz/corpus: afl's coverage queue after ≥ 10⁶
//! executions per target; tools/fuzz/regressions: inputs that once crashed) through the very
//! harness the fuzzer ran, so a fixed crash stays fixed. docs/CONTRIBUTING.md "Fuzzing".

#[path = "../tools/fuzz/src/lib.rs"]
mod harness;

use std::path::Path;

#[test]
fn every_fuzz_input_is_refused_or_loaded_cleanly() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("tools/fuzz");
    let mut counts = Vec::new();
    for target in harness::TARGETS {
        let mut n = 0;
        for dir in ["seeds", "corpus", "regressions"] {
            let Ok(entries) = std::fs::read_dir(root.join(dir).join(target)) else {
                continue;
            };
            for e in entries {
                let p = e.unwrap().path();
                let data = std::fs::read(&p).unwrap();
                let r = std::panic::catch_unwind(|| harness::run(target, &data));
                assert!(r.is_ok(), "fuzz target {target} panics on {}", p.display());
                n += 1;
            }
        }
        counts.push((*target, n));
    }
    eprintln!("replayed {counts:?}");
    // Every target has its seeds and a corpus: an empty folder would make this test pass
    // vacuously.
    for (t, n) in counts {
        assert!(n >= 5, "fuzz target {t} has only {n} inputs to replay");
    }
}
