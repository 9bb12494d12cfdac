#!/usr/bin/env bash
# Open a flowvo report in headless Chromium and save a full-page screenshot, to check it as a person would.
# Needs Debian's chromium (apt-get install chromium). Usage: scripts/screenshot_report.sh REPORT_DIR OUT.png
set -euo pipefail
report="$(cd "$1" && pwd)/index.html"
out="$2"
[ -f "$report" ] || { echo "no index.html in $1" >&2; exit 2; }
profile="$(mktemp -d)"
trap 'rm -rf "$profile"' EXIT
chromium --headless --no-sandbox --disable-gpu --disable-quic --no-first-run --disable-background-networking \
  --disable-component-update --disable-sync --user-data-dir="$profile" --hide-scrollbars \
  --window-size=1200,"${HEIGHT:-5200}" --screenshot="$out" "file://$report" 2>/dev/null
echo "screenshot: $out"
