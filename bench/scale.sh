#!/usr/bin/env bash
# Time, peak memory and throughput of `sawyer run` over log length and resolution (issue 24,
# item 3; docs/ct_input.md "Scale").
#
#   bench/scale.sh                      logs of 1, 2, 4 and 6 m in every configuration
#   bench/scale.sh --quick              1 and 2 m only, a smoke run
#   bench/scale.sh --ready              only the configurations whose phantom is made already
#   bench/scale.sh --only 1024-0.4-2    only these rows (comma-separated: gran1, 512-0.8-5,
#                                       512-0.8-1, 1024-0.4-2); tables of several runs combine
#                                       with build/bench/scale_bench table <(cat results-*.jsonl)
#   bench/scale.sh [--quick] [--ready] -- OPTS   OPTS passed to every `sawyer run` (e.g. -- --memory 400)
#
# Configurations (pixels, pixel size, slice spacing): 512² 0.8 mm 5 mm, 512² 0.8 mm 1 mm and
# 1024² 0.4 mm 2 mm, all a 409.6 mm field of view. One generated 6.2 m spruce (seed 24, 200 mm at
# the top, 256 mm at the butt) is synthesised once per configuration as a DICOM series; the
# 1, 2, 4 and 6 m logs are the first 1, 2, 4 and 6 m of slices of that scan (folders of symlinks,
# which the DICOM reader follows). The bundled 4 m log's scan, out/gran1_ct (made as
# scripts/demo.sh makes it), is a row too. Each row is one `sawyer run SCAN -o OUT --no-register`
# in a fresh process, measured by build/bench/scale_bench (wait4: wall, CPU, peak RSS; run.json:
# the scan stage; the scanned model against the phantom's truth/). The slices are read once
# before the runs of a configuration so that the table measures Sawyer, not the disk.
# Work folder: build/bench-scale (phantoms kept, so a rerun skips them; delete it to start
# again). Making the phantoms takes long on 2 cores (1024² at 2 mm: about 13 min; they are made
# niced). The table is also written to build/bench-scale/table.md.
set -euo pipefail
cd "$(dirname "$0")/.."
ROOT=$PWD
BUILD=${BUILD:-build}
WORK=$ROOT/build/bench-scale
LENGTHS="1 2 4 6"
EXTRA=()
READY=0
ONLY=gran1,512-0.8-5,512-0.8-1,1024-0.4-2
while [ $# -gt 0 ]; do
  case $1 in
    --quick) LENGTHS="1 2"; shift ;;
    --ready) READY=1; shift ;;
    --only) ONLY=${2:?--only needs a list}; shift 2 ;;
    --) shift; EXTRA=("$@"); break ;;
    *) echo "scale.sh: unknown option '$1' (--quick, --ready, --only LIST, or -- and sawyer run options)" >&2
       exit 1 ;;
  esac
done

. bench/build_for_bench.sh
bench_build "$BUILD" sawyer scale_bench
SAWYER=$ROOT/$BUILD/apps/sawyer/sawyer
BENCH=$ROOT/$BUILD/bench/scale_bench

mkdir -p "$WORK"
MODEL=$WORK/log.json
if [ ! -f "$MODEL" ]; then
  "$SAWYER" generate --species spruce --length-m 6.2 --seed 24 --top-diameter-mm 200 \
    --position middle -o "$MODEL" >/dev/null
fi

# phantom SIZE PIXEL SPACING: the configuration's DICOM scan of the whole model (made once).
phantom() {
  local d=$WORK/phantom-$1-$2-$3
  if [ ! -f "$d/truth/phantom.json" ]; then
    echo "making the phantom $1² $2 mm $3 mm (once; slow) ..." >&2
    exec 9>"$d.lock"
    flock -n 9 || { echo "scale.sh: another run is making $d" >&2; exit 1; }
    rm -rf "$d.partial"
    nice -n 10 "$SAWYER" phantom "$MODEL" -o "$d.partial" --size "$1" --pixel-mm "$2" \
      --spacing-mm "$3" >"$d.log" 2>&1 || { echo "scale.sh: phantom failed, see $d.log" >&2; exit 1; }
    mv "$d.partial" "$d"
  fi
  echo "$d"
}

# prefix SCAN N: a folder of symlinks to the first N slices of SCAN (remade when N differs).
prefix() {
  local d=$WORK/scans/$(basename "$1")-$2
  if [ "$(find "$d" -maxdepth 1 -name '*.dcm' 2>/dev/null | wc -l)" != "$2" ]; then
    rm -rf "$d"
    mkdir -p "$d"
    find "$1" -maxdepth 1 -name 'slice_*.dcm' | sort | awk -v n="$2" 'NR <= n' |
      xargs -d '\n' ln -s -t "$d"
  fi
  echo "$d"
}

wanted() { [[ ",$ONLY," == *",$1,"* ]]; }
if wanted gran1 && [ ! -f out/gran1_ct/truth/phantom.json ]; then
  echo "making out/gran1_ct as scripts/demo.sh does (once) ..." >&2
  nice -n 10 "$SAWYER" phantom sample_logs/gran1_spruce/log.json -o out/gran1_ct --seed 1 >/dev/null
fi

STAMP=$(date -u +%Y%m%dT%H%M%SZ)
RESULTS=$WORK/results-$STAMP.jsonl
: >"$RESULTS"
RUNS=$WORK/runs
mkdir -p "$RUNS"
warm() { find -L "$1" -maxdepth 1 -name '*.dcm' -print0 | xargs -0 cat >/dev/null; }

echo "running (results in $RESULTS) ..." >&2
if wanted gran1; then
  warm out/gran1_ct
  "$BENCH" run --scan out/gran1_ct --out "$RUNS/gran1" --results "$RESULTS" \
    --config "gran1 512² 0.8/5 mm" --length-m 4 --size 512 --truth out/gran1_ct/truth \
    --sawyer "$SAWYER" -- "${EXTRA[@]}"
fi
for cfg in "512 0.8 5" "512 0.8 1" "1024 0.4 2"; do
  set -- $cfg
  wanted "$1-$2-$3" || continue
  if [ $READY = 1 ] && [ ! -f "$WORK/phantom-$1-$2-$3/truth/phantom.json" ]; then
    echo "skipped: $1² $2/$3 mm (its phantom is not made yet)" >>"$WORK/skipped-$STAMP"
    continue
  fi
  scan=$(phantom "$1" "$2" "$3")
  longest=0
  for L in $LENGTHS; do longest=$L; done
  warm "$(prefix "$scan" "$(awk -v l="$longest" -v s="$3" 'BEGIN { printf "%d", l * 1000 / s + 0.5 }')")"
  for L in $LENGTHS; do
    n=$(awk -v l="$L" -v s="$3" 'BEGIN { printf "%d", l * 1000 / s + 0.5 }')
    "$BENCH" run --scan "$(prefix "$scan" "$n")" --out "$RUNS/$1-$2-$3-${L}m" \
      --results "$RESULTS" --config "$1² $2/$3 mm" --length-m "$L" --size "$1" \
      --truth "$scan/truth" --sawyer "$SAWYER" -- "${EXTRA[@]}"
  done
done

{
  echo "bench/scale.sh${EXTRA[*]:+ -- ${EXTRA[*]}}, $(date -u '+%Y-%m-%d %H:%M UTC'), commit" \
    "$(git rev-parse --short HEAD)$(git diff --quiet HEAD -- . 2>/dev/null || echo ' (modified)')," \
    "$(nproc) cores, load $(cut -d' ' -f1-3 /proc/loadavg)"
  echo
  "$BENCH" table "$RESULTS"
  [ ! -f "$WORK/skipped-$STAMP" ] || { echo; cat "$WORK/skipped-$STAMP"; }
  if awk '{ exit !($1 > 2.5) }' /proc/loadavg; then
    echo
    echo "load average above 2.5 on $(nproc) cores: other work shared the CPUs, so times and" \
      "voxels/s are lower bounds (CPU s is the steadier figure)"
  fi
} | tee "$WORK/table.md"
