#!/usr/bin/env bash
# Runs every test: installs what is missing, builds, runs the gtest suites (core, io, CLI) and
# the ROS tests (rostest, bag replay), the core's gtests under sanitizers and a 60 s fuzz run
# (scripts/sanitize.sh, scripts/fuzz.sh) and the RViz demo's screenshot check
# (scripts/rviz_demo_check.sh), then prints one summary line "N passed, N failed".
set -euo pipefail
cd "$(dirname "$0")/.."
./scripts/install_deps.sh
source scripts/env.sh
./scripts/build.sh tests

results="$SPOOL_WS/build/test_results"
rm -rf "$results"
# run_tests keeps going past a failing suite; the summary below decides the exit code.
(cd "$SPOOL_WS" && catkin_make run_tests -j1 >"$SPOOL_WS/run_tests.log" 2>&1) || true
grep -E '^\[ *(RUN|OK|FAILED|PASSED) *\]|^\[ROSTEST\]|^\[Testcase|FAILURE|ERROR' "$SPOOL_WS/run_tests.log" | tail -n 400 || true

# The core's gtests under AddressSanitizer + UndefinedBehaviorSanitizer, then a short libFuzzer
# run (60 s over its targets), both built with clang outside catkin. They write JUnit files into
# the results, so the summary counts them; a run that fails before writing one (e.g. its build)
# counts as one failed test.
counted() {
  local name="$1"
  shift
  local status=0
  SPOOL_TEST_RESULTS="$results/$name" "$@" >"$SPOOL_WS/$name.log" 2>&1 || status=$?
  tail -n 30 "$SPOOL_WS/$name.log"
  if [ "$status" -ne 0 ] && ! ls "$results/$name"/*.xml >/dev/null 2>&1; then
    mkdir -p "$results/$name"
    printf '<testsuite name="%s"><testcase classname="%s" name="run"><failure message="exit %s, see %s"/></testcase></testsuite>\n' \
      "$name" "$name" "$status" "$SPOOL_WS/$name.log" >"$results/$name/run.xml"
  fi
}
counted sanitizers ./scripts/sanitize.sh
counted fuzz ./scripts/fuzz.sh 60
# demo.launch rviz:=true in Xvfb: a screenshot of RViz checked for the spool, its TF frame and pose.
counted rviz_demo ./scripts/rviz_demo_check.sh

/usr/bin/python3 - "$results" <<'PY'
import glob, sys, xml.etree.ElementTree as ET
passed = failed = skipped = 0
suites = 0
def failing(case):
    return case.find("failure") is not None or case.find("error") is not None
for path in glob.glob(sys.argv[1] + "/**/*.xml", recursive=True):
    root = ET.parse(path).getroot()
    for case in root.iter("testcase"):
        if case.find("skipped") is not None:
            skipped += 1
        elif failing(case):
            failed += 1
            print("FAILED:", path.split("/")[-1], case.get("classname"), case.get("name"))
        else:
            passed += 1
    # A suite that errored before its cases ran (a rostest node timing out in its set-up) reports
    # errors with no failing case to show for them: each counts as a failed test.
    for suite in [root] if root.tag == "testsuite" else root.findall(".//testsuite"):
        reported = sum(int(suite.get(key) or 0) for key in ("errors", "failures"))
        shown = sum(1 for case in suite.iter("testcase") if failing(case))
        if reported > shown:
            failed += reported - shown
            print("FAILED:", path.split("/")[-1], suite.get("name"), f"{reported - shown} error(s) outside its test cases")
    suites += 1
if suites == 0 or passed + failed == 0:
    print("no test results found in", sys.argv[1])
    failed += 1
print(f"{passed} passed, {failed} failed" + (f", {skipped} skipped" if skipped else ""))
sys.exit(1 if failed else 0)
PY
