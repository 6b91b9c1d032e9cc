#!/usr/bin/env bash
# Runs each named target (default: all) for EXECS executions with afl++, then copies its
# queue into corpus/TARGET, the corpus tests/fuzz_corpus.rs replays. README "Fuzzing".
set -euo pipefail
cd "$(dirname "$0")"
EXECS="${EXECS:-1000000}"
export AFL_SKIP_CPUFREQ=1 AFL_I_DONT_CARE_ABOUT_MISSING_CRASHES=1 AFL_NO_UI=1
cargo afl build --release
targets=("$@")
[ ${#targets[@]} -gt 0 ] || targets=(exr hdr pfm dds png jpeg scene)
for t in "${targets[@]}"; do
  rm -rf "out/$t"
  # -m: a 512 MB memory limit makes an unbounded allocation a crash; -t: 1 s makes a hang one.
  cargo afl fuzz -i "seeds/$t" -o "out/$t" -m 512 -t 1000 -E "$EXECS" target/release/fuzz "$t" \
    > "out/$t.log" 2>&1 || true
  stats="out/$t/default/fuzzer_stats"
  execs=$(awk -F' *: *' '$1=="execs_done"{print $2}' "$stats")
  crashes=$(awk -F' *: *' '$1=="saved_crashes"{print $2}' "$stats")
  hangs=$(awk -F' *: *' '$1=="saved_hangs"{print $2}' "$stats")
  secs=$(( $(awk -F' *: *' '$1=="last_update"{print $2}' "$stats") - $(awk -F' *: *' '$1=="start_time"{print $2}' "$stats") ))
  # The queue is afl's set of inputs with distinct coverage; it becomes the corpus, renamed.
  rm -rf "corpus/$t" && mkdir -p "corpus/$t"
  i=0
  for f in out/$t/default/queue/id*; do
    cp "$f" "corpus/$t/$(printf %05d $i)"; i=$((i+1))
  done
  mkdir -p "regressions/$t"
  for f in out/$t/default/crashes/id* out/$t/default/hangs/id*; do
    [ -e "$f" ] && cp "$f" "regressions/$t/found_$(date +%s)_$(basename "$f" | cut -c1-9)"
  done
  echo "$t: $execs executions in ${secs} s, $crashes crashes, $hangs hangs, corpus $(ls corpus/$t | wc -l) files" | tee -a out/summary.txt
done
