#!/usr/bin/env bash
# Regenerates what is derived from include/novelty_detection/params.h: config/default.yaml
# and the parameter table in README.md (between the PARAMETERS markers). Needs a build.
set -euo pipefail
source "$(dirname "${BASH_SOURCE[0]}")/common.sh"
BIN="$WS/devel/lib/novelty_detection"
[ -x "$BIN/print_params" ] || bash "$REPO/scripts/build.sh"
"$BIN/print_params" --yaml > "$REPO/config/default.yaml"
table=$("$BIN/print_params" --markdown)
python3 - "$REPO/README.md" "$table" <<'PY'
import sys
path, table = sys.argv[1], sys.argv[2]
text = open(path).read()
begin, end = "<!-- PARAMETERS BEGIN -->", "<!-- PARAMETERS END -->"
if begin not in text or end not in text:
    sys.exit("README.md lacks the PARAMETERS markers")
head, rest = text.split(begin, 1)
_, tail = rest.split(end, 1)
open(path, "w").write(head + begin + "\n" + table.rstrip("\n") + "\n" + end + tail)
PY
log "regenerated config/default.yaml and the README parameter table"
