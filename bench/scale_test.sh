#!/usr/bin/env bash
# Test of bench/scale_bench (ctest ScaleBench): its fits and verdicts on rows whose answers are
# known, a real `sawyer run` of a short phantom scored against the phantom's own truth, and a
# failed run recorded as such.
#
#   bench/scale_test.sh SCALE_BENCH SAWYER
set -euo pipefail
BENCH=$1
SAWYER=$2
SRC=$(cd "$(dirname "$0")/.." && pwd)
T=$(mktemp -d)
trap 'rm -rf "$T"' EXIT
fail() { echo "FAIL: $*" >&2; exit 1; }

# 1. Fits: scan seconds = 0.5 + 8 ns x voxels; peak MB = 300 + 40 MB/m in configuration A and
# 350 MB in B but 900 MB for its 6 m row (slope 102.5 MB/m); gran1 at 380 MB; the slowest row
# A's 1 m one, 5e7 voxels in 0.9 s (55.6 M voxels/s).
row() {  # config length voxels scan_s peak_mb
  printf '{"config":"%s","length_m":%s,"rc":0,"slices":1,"voxels":%s,"stages":{"scan":%s},' \
    "$1" "$2" "$3" "$4"
  printf '"wall_s":1,"cpu_s":1,"peak_mb":%s}\n' "$5"
}
{
  row "gran1 512" 4 2e8 2.1 380
  for L in 1 2 4 6; do
    v=$(awk -v l=$L 'BEGIN { print l * 5e7 }')
    row "A 512" $L "$v" "$(awk -v v="$v" 'BEGIN { print 0.5 + 8e-9 * v }')" $((300 + 40 * L))
    row "B 1024" $L "$v" "$(awk -v v="$v" 'BEGIN { print 0.5 + 8e-9 * v }')" \
      "$([ $L = 6 ] && echo 900 || echo 350)"
  done
  echo '{"config":"C 512","length_m":1,"rc":3,"peak_mb":12,"error":"sawyer: over the budget"}'
} >"$T/rows.jsonl"
"$BENCH" table "$T/rows.jsonl" >"$T/table.md"
cat "$T/table.md"
grep -q '| A 512 | 8.00 ns/voxel | 0.50 s | 40.0 MB/m |' "$T/table.md" || fail "fit of A"
grep -q '| B 1024 | 8.00 ns/voxel | 0.50 s | ' "$T/table.md" || fail "fit of B"
grep -q 'FAILED (exit 3): sawyer: over the budget' "$T/table.md" || fail "failed row"
grep -q 'bundled 4 m log (gran1), report included | met (380.0 MB)' "$T/table.md" ||
  fail "gran1 target"
grep -q '6 m log at 1024² | MISSED by 100.0 MB (900.0 MB)' "$T/table.md" || fail "6 m target"
grep -q 'steepest configuration: B 1024) | MISSED by 97.5 MB/m (102.5 MB/m)' "$T/table.md" ||
  fail "slope target"
grep -q 'slowest row: A 512, 1.0 m) | MISSED by 32.4 M voxels/s (55.6' "$T/table.md" ||
  fail "throughput target"
# Against gran1's 95.2 M voxels/s: A's 1 m row at 58 %.
grep -q '| A 512 | 1.0 | 1 | 50 | 0.90 | 1.00 | 1.0 | 340 | 55.6 | 58 % |' "$T/table.md" ||
  fail "rate against gran1"
grep -q 'slowest row: A 512, 1.0 m) | MISSED by 21.7 % (58.3 %)' "$T/table.md" ||
  fail "relative throughput target"

# 2. A real run: 40 slices of the bundled spruce, scored against the phantom's truth.
"$SAWYER" phantom "$SRC/sample_logs/gran1_spruce/log.json" -o "$T/ct" --from-mm 1000 \
  --to-mm 1195 --seed 3 >/dev/null 2>&1 || fail "phantom"
"$BENCH" run --scan "$T/ct" --out "$T/run" --results "$T/real.jsonl" --config "real 512" \
  --length-m 0.2 --size 512 --truth "$T/ct/truth" --sawyer "$SAWYER" -- --no-report --threads 2
python3 - "$T/real.jsonl" <<'EOF' || fail "real run's row"
import json, sys
r = json.loads(open(sys.argv[1]).read().splitlines()[-1])
assert r["rc"] == 0, r
assert r["slices"] == 40 and r["voxels"] == 40 * 512 * 512, r
assert r["peak_mb"] > 20 and r["wall_s"] > 0 and r["stages"]["scan"] > 0, r
assert r["pith_median_mm"] < 0.5, r       # the scanned pith where the truth has it
assert r["outline_rms_mm"] < 1.5, r
assert r["knots_found"] >= 1 and r["knots_true_found"] >= 1, r
assert "--no-report" in r["command"], r   # the extra options reach sawyer run
EOF

# 3. A scan that is not there: the row says so, the bench itself succeeds.
"$BENCH" run --scan "$T/nothing" --out "$T/run2" --results "$T/real.jsonl" --config "bad" \
  --length-m 1 --size 512 --sawyer "$SAWYER"
python3 - "$T/real.jsonl" <<'EOF' || fail "a failed run's row"
import json, sys
r = json.loads(open(sys.argv[1]).read().splitlines()[-1])
assert r["rc"] != 0 and "nothing" in r["error"], r
EOF
echo "scale_test: ok"
