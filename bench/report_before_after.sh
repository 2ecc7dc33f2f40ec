#!/bin/bash
# The cutting report's step times before and after a change (docs/report.md, Speed): runs
# `sawyer report` on one run folder with two binaries in turn, five rounds, the second also at
# --board-detail 9. One line per run: the report's own step times (--verbose), then wall, user
# and sys seconds from /usr/bin/time.
#
#   bench/report_before_after.sh <before/sawyer> <after/sawyer> <run folder> [rounds]
set -euo pipefail
before=$1 after=$2 dir=$3 rounds=${4:-5}
run() {  # label binary args...
  local label=$1 bin=$2
  shift 2
  printf '%-8s ' "$label"
  /usr/bin/time -f "TIME %e %U %S" "$bin" report "$dir" -q --verbose "$@" 2>&1 |
    awk '/^TIME/{t=sprintf("wall=%s user=%s sys=%s", $2, $3, $4); next}
         /^[a-z3][a-zA-Z ]* +[0-9.]+$/{n=$NF; $NF=""; gsub(/ +$/,""); gsub(/ /,"_"); printf "%s=%s ", $0, n}
         END{print t}'
}
for ((round = 1; round <= rounds; ++round)); do
  run before "$before"
  run after "$after"
  run after9 "$after" --board-detail 9
done
