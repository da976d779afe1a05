#!/usr/bin/env bash
# Fuzzes the core with libFuzzer under AddressSanitizer and UndefinedBehaviorSanitizer:
#   ./scripts/fuzz.sh [SECONDS] [TARGET...]
# SECONDS (default 60) is the whole run's time, split evenly over the targets (default all:
# detector_fuzz, params_yaml_fuzz, camera_info_fuzz; sources and seed corpora in test/fuzz).
# Leak detection is on and an input may use at most 2 GB and 25 s. Each target's corpus grows in
# build/fuzz/corpus/<target> (seeded from test/fuzz/corpus/<target>); an input that crashes,
# leaks, times out or runs out of memory is kept in build/fuzz/crashes/<target>/ and the run
# fails (exit 1). Reproduce one with build/sanitizers/<target> <file>. With SPOOL_TEST_RESULTS
# set, a JUnit file there records one test per target (scripts/test.sh counts them).
set -euo pipefail
cd "$(dirname "$0")/.."
seconds="${1:-60}"
shift || true
targets=("$@")
[ ${#targets[@]} -gt 0 ] || targets=(detector_fuzz params_yaml_fuzz camera_info_fuzz)
per_target=$(( seconds / ${#targets[@]} ))
[ "$per_target" -ge 1 ] || per_target=1

./scripts/clang_build.sh "${targets[@]}"
source scripts/env.sh
out="$SPOOL_ROOT/build/fuzz"
mkdir -p "$out"
symbolizer="$(command -v llvm-symbolizer || true)"
export ASAN_OPTIONS="detect_leaks=1:abort_on_error=1:symbolize=1${symbolizer:+:external_symbolizer_path=$symbolizer}"
export UBSAN_OPTIONS="print_stacktrace=1:halt_on_error=1"

failed=0
total=0
cases=""
for target in "${targets[@]}"; do
  corpus="$out/corpus/$target"
  crashes="$out/crashes/$target"
  mkdir -p "$corpus" "$crashes"
  # The detector reads a 16-byte header and then up to 16 KB of pixels (repeated to fill the frame).
  max_len=8192
  [ "$target" = detector_fuzz ] && max_len=16400
  log="$out/$target.log"
  start=$(date +%s)
  status=0
  "$SPOOL_ROOT/build/sanitizers/$target" "$corpus" "test/fuzz/corpus/$target" \
    -max_total_time="$per_target" -rss_limit_mb=2048 -malloc_limit_mb=2048 -timeout=25 -detect_leaks=1 \
    -max_len="$max_len" -print_final_stats=1 -artifact_prefix="$crashes/" >"$log" 2>&1 || status=$?
  elapsed=$(( $(date +%s) - start ))
  runs=$(sed -n 's/^stat::number_of_executed_units: *//p' "$log" | tail -n 1)
  runs="${runs:-0}"
  total=$(( total + runs ))
  if [ "$status" -eq 0 ]; then
    echo "$target: $runs executions in ${elapsed} s, no crash, no leak"
    cases+="  <testcase classname=\"fuzz\" name=\"$target\" time=\"$elapsed\"/>"$'\n'
  else
    failed=$(( failed + 1 ))
    artifact=$(sed -n 's/.*Test unit written to //p' "$log" | tail -n 1)
    reason=$(grep -m1 -E 'ERROR: (AddressSanitizer|LeakSanitizer|libFuzzer)|runtime error:|detector_fuzz:|_fuzz: ' "$log" || echo "exit status $status")
    echo "$target: FAILED after $runs executions in ${elapsed} s: $reason"
    echo "  input: ${artifact:-none written}; log: $log"
    grep -A 30 -m1 -E 'ERROR: |runtime error:' "$log" | head -n 40 || true
    reason_xml=$(printf '%s' "$reason" | sed 's/&/\&amp;/g; s/</\&lt;/g; s/>/\&gt;/g; s/"/\&quot;/g')
    cases+="  <testcase classname=\"fuzz\" name=\"$target\" time=\"$elapsed\"><failure message=\"$reason_xml\"/></testcase>"$'\n'
  fi
done

if [ -n "${SPOOL_TEST_RESULTS:-}" ]; then
  mkdir -p "$SPOOL_TEST_RESULTS"
  printf '<?xml version="1.0"?>\n<testsuite name="fuzz" tests="%d" failures="%d">\n%s</testsuite>\n' \
    "${#targets[@]}" "$failed" "$cases" >"$SPOOL_TEST_RESULTS/fuzz.xml"
fi
if [ "$failed" -eq 0 ]; then
  echo "fuzz: PASS (${#targets[@]} targets, $total executions, ${seconds} s)"
else
  echo "fuzz: FAIL ($failed of ${#targets[@]} targets; crash inputs in $out/crashes)"
  exit 1
fi
