#!/usr/bin/env bash
# Read throughput and peak memory of every CT reader (issue 3).
#
#   bench/ct_read.sh            the whole 4 m sample spruce: 800 slices of 512 x 512, 0.8 mm, 5 mm
#   bench/ct_read.sh --short    a 200-slice section (1 m), for a quick look
#
# Makes a phantom of sample_logs/gran1_spruce once (DICOM), converts it to every other format,
# then reads each one twice in fresh processes and prints the second read as one table row per
# format: slices/s, MB/s (16-bit stored size) and the process's peak RSS. The first read warms
# the page cache, so the table measures the readers, not the disk (a cold read of the 420 MB
# DICOM series from this machine's disk ran at about 100 MB/s). Work folder: build/bench-ct (kept, so a
# rerun skips the phantom; delete it to start again).
set -euo pipefail
cd "$(dirname "$0")/.."
ROOT=$PWD
BUILD=${BUILD:-build}
WORK=$ROOT/build/bench-ct
FROM=""; TO=""; TAG=full
if [ "${1:-}" = "--short" ]; then FROM="--from-mm 1000"; TO="--to-mm 1995"; TAG=short; fi

scripts/install_deps.sh >/dev/null
. bench/build_for_bench.sh
bench_build "$BUILD" sawyer ct_read_bench
SAWYER=$ROOT/$BUILD/apps/sawyer/sawyer
BENCH=$ROOT/$BUILD/bench/ct_read_bench

mkdir -p "$WORK"
if [ ! -d "$WORK/$TAG-dicom" ]; then
  echo "making the phantom ($TAG) ..." >&2
  "$SAWYER" phantom sample_logs/gran1_spruce/log.json -o "$WORK/$TAG-dicom" \
    --size 512 --pixel-mm 0.8 --spacing-mm 5 $FROM $TO >&2
fi
for f in tiff multitiff png mha nrrd vti; do
  if [ ! -d "$WORK/$TAG-$f" ]; then
    echo "converting to $f ..." >&2
    "$BENCH" convert "$WORK/$TAG-dicom" "$WORK/$TAG-$f" "$f"
  fi
done

echo
echo "CT read throughput, sample spruce phantom ($TAG), $(nproc) cores"
echo
echo "| format                 | slices | size      | seconds | slices/s |    MB/s | peak RSS MB | checksum |"
echo "|------------------------|-------:|-----------|--------:|---------:|--------:|------------:|---------:|"
for f in dicom tiff multitiff png mha nrrd vti; do
  "$BENCH" read "$WORK/$TAG-$f" >/dev/null   # warm the page cache (see the header)
  "$BENCH" read "$WORK/$TAG-$f"
done
