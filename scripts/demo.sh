#!/usr/bin/env bash
# The demo: installs, builds, renders a short approach (110 -> 50 cm, ending aligned) with the
# package's own renderer and runs spool_detect on it, one JSON line per frame, then a summary.
set -euo pipefail
cd "$(dirname "$0")/.."
./scripts/install_deps.sh
source scripts/env.sh
./scripts/build.sh
bin="$SPOOL_WS/devel/lib/spool_vision"
frames="$SPOOL_ROOT/build/demo_approach"
rm -rf "$frames"
"$bin/spool_render" --out "$frames" --width 640 --height 480 --set approach --count 20 >/dev/null
"$bin/spool_detect" --config config/default.yaml --camera-info "$frames/camera_info.yaml" "$frames" | tee "$frames/poses.jsonl"
/usr/bin/python3 - "$frames/poses.jsonl" <<'PY'
import json, sys
rows = [json.loads(l) for l in open(sys.argv[1])]
det = sum(r.get("detected", False) for r in rows)
aligned = sum(r.get("aligned", False) for r in rows)
ms = sorted(r["time_ms"] for r in rows if "time_ms" in r)
print(f"demo: {len(rows)} frames, {det} detected, {aligned} aligned, median {ms[len(ms)//2]:.2f} ms/frame")
PY
