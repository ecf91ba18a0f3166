#!/usr/bin/env bash
# The real-data tables: the real-scan pairs of test/real (Kinect tabletop pairs with labels,
# the ETH apartment and PCL room laser pairs) and the semi-real scenes (an object ray-cast
# into a real sweep), run with the defaults and the stated sensor origins and up,
# printed as Markdown with the commit, and the pictures of what is flagged on the unchanged
# laser pairs (docs/images/eth_flags.png and room_flags.png, with python3-matplotlib). Needs the real-scan data set
# (NOVELTY_REAL_DATA, see scripts/common.sh) and a build (scripts/build.sh).
#   bash scripts/evaluate_real.sh
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/common.sh"
BIN="$WS/devel/lib/novelty_detection/test_real_pairs"
ROOM="$WS/devel/lib/novelty_detection/test_room_scans"
[ -n "$NOVELTY_REAL_DATA" ] || { log "no real-scan data: set NOVELTY_REAL_DATA"; exit 1; }
[ -x "$BIN" ] && [ -x "$ROOM" ] || bash "$REPO/scripts/build.sh" test_real_pairs test_room_scans
echo "Real scans ($(git -C "$REPO" rev-parse --short HEAD), $(nproc) cores; \`bash scripts/evaluate_real.sh\`):"
echo
FLAGS="$(mktemp -d)"
trap 'rm -rf "$FLAGS"' EXIT
# One run of the real-pair tests: its rows for both tables and the ETH pair's labels.
NOVELTY_REAL_OUT="$FLAGS" "$BIN" > "$FLAGS/rows.txt" 2>/dev/null || true
NOVELTY_REAL_OUT="$FLAGS" "$ROOM" >> "$FLAGS/rows.txt" 2>/dev/null || true
echo "| pair | origins and up | precision | recall | F1 | segments | up used |"
echo "|---|---|---:|---:|---:|---:|---|"
grep '^| [a-z0-9]*\.pcd' "$FLAGS/rows.txt" || true
echo
echo "| pair | origins and up | result |"
echo "|---|---|---|"
grep -E '^\| (eth|room) ' "$FLAGS/rows.txt" || true
grep '^registration' "$FLAGS/rows.txt" | sed 's/^/\nRoom pair /' || true
draw() {  # draw NAME TITLE: docs/images/NAME.png from the labels the tests wrote
  if /usr/bin/python3 -c "import matplotlib" 2>/dev/null && [ -f "$FLAGS/$1.txt" ]; then
    mkdir -p "$REPO/docs/images"
    /usr/bin/python3 "$REPO/scripts/plot_flags.py" "$FLAGS/$1.txt" "$REPO/docs/images/$1.png" "$2"
    log "picture: docs/images/$1.png"
  else
    log "python3-matplotlib or the labels missing: no docs/images/$1.png"
  fi
}
draw eth_flags "ETH apartment, unchanged pair (published registration): what is flagged"
draw room_flags "PCL room scans, unchanged pair (documented registration): what is flagged"
SEMI="$WS/devel/lib/novelty_detection/test_semireal"
[ -x "$SEMI" ] || bash "$REPO/scripts/build.sh" test_semireal
echo
echo "Semi-real scenes: a real person (cut from pcl_test_indoor_scenes/five_people.pcd) or a"
echo "0.5 x 0.4 x 0.6 m box ray-cast into the current sweep at seeded free floor placements."
echo
echo "| scene | placement | points inserted | best segment IoU | segments | other points labelled |"
echo "|---|---|---:|---:|---:|---:|"
"$SEMI" 2>/dev/null | grep '^| [a-z]* + ' || true
