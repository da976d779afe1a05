#!/usr/bin/env bash
# Runs the core's gtests (test_core, test_io, test_heldout_cases) built with clang under
# AddressSanitizer (with leak detection) and UndefinedBehaviorSanitizer; undefined behaviour
# aborts the run (-fno-sanitize-recover). Prints one line per suite and PASS or FAIL; exit 1 on
# a failed test or any sanitizer report. With SPOOL_TEST_RESULTS set, each suite's gtest XML and
# one "exit clean" test per suite (a sanitizer report ends the process after its tests passed)
# go there for scripts/test.sh's summary.
set -euo pipefail
cd "$(dirname "$0")/.."
suites=(test_core_sanitized test_io_sanitized test_heldout_cases_sanitized)
./scripts/clang_build.sh "${suites[@]}"
source scripts/env.sh
out="$SPOOL_ROOT/build/sanitizers"
symbolizer="$(command -v llvm-symbolizer || true)"
export ASAN_OPTIONS="detect_leaks=1:abort_on_error=1:symbolize=1${symbolizer:+:external_symbolizer_path=$symbolizer}"
export UBSAN_OPTIONS="print_stacktrace=1:halt_on_error=1"

failed=0
cases=""
for suite in "${suites[@]}"; do
  log="$out/$suite.log"
  xml_option=()
  [ -n "${SPOOL_TEST_RESULTS:-}" ] && xml_option=("--gtest_output=xml:$SPOOL_TEST_RESULTS/$suite.xml")
  mkdir -p "${SPOOL_TEST_RESULTS:-$out}"
  start=$(date +%s)
  status=0
  "$out/$suite" "${xml_option[@]}" >"$log" 2>&1 || status=$?
  elapsed=$(( $(date +%s) - start ))
  summary=$(grep -E '^\[  (PASSED|FAILED)  \] [0-9]+ test' "$log" | tr '\n' ' ' || true)
  if [ "$status" -eq 0 ]; then
    echo "$suite: ok in ${elapsed} s ${summary}"
    cases+="  <testcase classname=\"sanitizers\" name=\"${suite}_exit_clean\" time=\"$elapsed\"/>"$'\n'
  else
    failed=$(( failed + 1 ))
    reason=$(grep -m1 -E 'ERROR: (Address|Leak)Sanitizer|runtime error:|^\[  FAILED  \]' "$log" || echo "exit status $status")
    echo "$suite: FAILED (exit $status) in ${elapsed} s: $reason; log: $log"
    grep -A 25 -m1 -E 'ERROR: |runtime error:' "$log" | head -n 30 || true
    reason_xml=$(printf '%s' "$reason" | sed 's/&/\&amp;/g; s/</\&lt;/g; s/>/\&gt;/g; s/"/\&quot;/g')
    cases+="  <testcase classname=\"sanitizers\" name=\"${suite}_exit_clean\" time=\"$elapsed\"><failure message=\"$reason_xml\"/></testcase>"$'\n'
  fi
done

if [ -n "${SPOOL_TEST_RESULTS:-}" ]; then
  printf '<?xml version="1.0"?>\n<testsuite name="sanitizers" tests="%d" failures="%d">\n%s</testsuite>\n' \
    "${#suites[@]}" "$failed" "$cases" >"$SPOOL_TEST_RESULTS/sanitizers_exit.xml"
fi
if [ "$failed" -eq 0 ]; then
  echo "sanitizers: PASS (${#suites[@]} suites under AddressSanitizer + UndefinedBehaviorSanitizer)"
else
  echo "sanitizers: FAIL ($failed of ${#suites[@]} suites)"
  exit 1
fi
