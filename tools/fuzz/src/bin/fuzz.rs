//! `cargo afl build --release && cargo afl fuzz -i seeds/T -o out/T target/release/fuzz T`
//! (docs/CONTRIBUTING.md "Fuzzing"): the target is the first argument.

fn main() {
    let target = std::env::args().nth(1).unwrap_or_default();
    assert!(
        envlight_fuzz::TARGETS.contains(&target.as_str()),
        "usage: fuzz TARGET, one of {:?}",
        envlight_fuzz::TARGETS
    );
    afl::fuzz_nohook!(|data: &[u8]| envlight_fuzz::run(&target, data));
}
