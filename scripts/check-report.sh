#!/usr/bin/env bash
# Checks the demo's report.html in a real browser: headless Chromium loads the
# page, any console message (a script error, a blocked or failed resource)
# fails the check, and a screenshot is saved for a person to look at.
#
# usage: scripts/check-report.sh [REPORT.html] [SCREENSHOT.png]
#   Without REPORT, runs the demo into a temporary folder first, with the
#   binary in $FLEXCAL_BIN (default: target/debug/flexcal, built if missing).
#   The screenshot defaults to report-screenshot.png beside the report.
# Chromium comes from Debian's packages; where it cannot be installed the
# check is skipped with a message (exit 0).
set -euo pipefail
cd "$(dirname "$0")/.."

report=${1:-}
if [ -z "$report" ]; then
  bin=${FLEXCAL_BIN:-target/debug/flexcal}
  [ -x "$bin" ] || cargo build --quiet --bin flexcal
  out=$(mktemp -d)/demo
  "$bin" demo --out "$out" >/dev/null
  report="$out/report.html"
fi
[ -f "$report" ] || { echo "check-report: no such file: $report" >&2; exit 1; }
shot=${2:-"$(dirname "$report")/report-screenshot.png"}

browser=$(command -v chromium || command -v chromium-browser || true)
if [ -z "$browser" ]; then
  if [ "$(id -u)" = 0 ] && command -v apt-get >/dev/null 2>&1; then
    echo "check-report: installing chromium from Debian's packages"
    if ! { apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq chromium; } >/tmp/check-report-apt.log 2>&1; then
      echo "check-report: SKIPPED: chromium could not be installed (see /tmp/check-report-apt.log)"
      exit 0
    fi
    browser=$(command -v chromium)
  else
    echo "check-report: SKIPPED: no chromium and no way to install it (needs root and apt-get)"
    exit 0
  fi
fi

# The page must not reach for anything outside itself.
if grep -Eq '<script[^>]+src=|<link[^>]+href=|<img[^>]+src="(https?:)?//' "$report"; then
  echo "check-report: FAILED: $report loads external resources" >&2
  exit 1
fi

profile=$(mktemp -d)
log=$(mktemp)
abs=$(cd "$(dirname "$report")" && pwd)/$(basename "$report")
timeout 120 "$browser" --headless --no-sandbox --disable-gpu --disable-quic --no-first-run \
  --disable-background-networking --disable-component-update --disable-sync \
  --user-data-dir="$profile" --enable-logging=stderr --v=0 --window-size=1100,1600 \
  --screenshot="$shot" "file://$abs" 2>"$log" || {
  echo "check-report: FAILED: chromium exited with an error (log: $log)" >&2
  exit 1
}
if grep -q ':CONSOLE' "$log"; then
  echo "check-report: FAILED: the page wrote to the console:" >&2
  grep ':CONSOLE' "$log" >&2
  exit 1
fi
[ -s "$shot" ] || { echo "check-report: FAILED: no screenshot written" >&2; exit 1; }
echo "check-report: OK: $report renders without console messages; screenshot $shot"
