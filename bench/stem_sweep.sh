#!/usr/bin/env bash
# Robustness of the stem pass (issue 4) over where a short scan starts and over noise draws.
#
#   bench/stem_sweep.sh [clean|hard] [seeds] [positions]
#   bench/stem_sweep.sh hard "1 2" "0.2 0.5 0.65 0.8"      (the default)
#
# stem_bench's table covers one 30 cm section in the middle of each log; this runs 20 cm sections
# (40 slices at 5 mm) of every log (the three bundled ones and four generated ones) centred at
# each position (a fraction of the log's length), for each phantom seed, and prints every section
# whose pith error misses the condition's targets (median / 95th percentile: clean 0.5 / 1.5 mm,
# hard 1.0 / 3.0 mm), then how many sections met them. The first pith of a scan is searched for
# on the slices at its very start, the hardest place, so short sections are the harshest test.
set -euo pipefail
cd "$(dirname "$0")/.."
BUILD=${BUILD:-build}
COND=${1:-hard}
SEEDS=${2:-1 2}
POSITIONS=${3:-0.2 0.5 0.65 0.8}
BENCH=$BUILD/bench/stem_bench
[ -x "$BENCH" ] || { echo "stem_sweep: $BENCH not built (cmake --build $BUILD --target stem_bench)" >&2; exit 1; }
case $COND in
  clean) MED=0.5; P95=1.5 ;;
  hard) MED=1.0; P95=3.0 ;;
  *) echo "stem_sweep: condition must be clean or hard, not '$COND'" >&2; exit 1 ;;
esac
ROWS=$(mktemp)
trap 'rm -f "$ROWS"' EXIT
for seed in $SEEDS; do
  for at in $POSITIONS; do
    echo "seed $seed, sections centred at $at of each log ..." >&2
    "$BENCH" --slices 40 --speed-slices 0 --random 4 --condition "$COND" --seed "$seed" --at "$at" |
      grep '^| [a-z]' | grep -v '^| log ' | sed "s/^/$seed $at /" >>"$ROWS"
  done
done
echo
echo "Stem pass on 20 cm sections, condition $COND (targets: median <= $MED mm, p95 <= $P95 mm)"
echo
echo "| seed | position | log | pith median mm | pith p95 mm | worst mm (slice) |"
echo "|---:|---:|---|---:|---:|---:|"
awk -F'|' -v med="$MED" -v p95="$P95" '
  { split($1, a, " "); total++
    if ($5 + 0 > med || $6 + 0 > p95) { printf "| %s | %s |%s|%s|%s|%s|\n", a[1], a[2], $2, $5, $6, $7; missed++ } }
  END { printf "\n%d of %d sections met the targets", total - missed, total
        if (missed) printf "; the rows above missed them"
        printf ".\n" }' "$ROWS"
