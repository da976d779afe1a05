#!/usr/bin/env bash
# The evaluation report: installs what is missing, builds spool_eval, renders the labelled sets
# and writes REPORT_DIR/report.md with its PNG charts (DESIGN.md §7 bars per resolution and set,
# and the thesis' chapter 4 analyses). The headline tables go to stdout, progress to stderr.
#   scripts/eval.sh [REPORT_DIR] [spool_eval options, e.g. --quick, --count N, --sizes WxH,...,
#                   --require-bars]
#   REPORT_DIR defaults to build/eval_report (git-ignored).
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
out="$root/build/eval_report"
if [ $# -gt 0 ] && [[ "$1" != -* ]]; then
  out="$(realpath -m "$1")"  # relative to where the script was called from
  shift
fi

"$root/scripts/install_deps.sh" >&2
source "$root/scripts/env.sh"
"$root/scripts/build.sh" spool_eval >&2

status=0
"$SPOOL_WS/devel/lib/spool_vision/spool_eval" --out "$out" "$@" || status=$?
# 3: it ran, and a default.yaml bar failed under --require-bars.
if [ "$status" -eq 0 ] || [ "$status" -eq 3 ]; then
  echo "eval: report in $out/report.md"
fi
exit "$status"
