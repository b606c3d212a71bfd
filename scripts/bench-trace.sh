#!/usr/bin/env bash
# bench-trace.sh — builds bench_trace (Release) and runs the ray-casting
# benchmark: splatgi MLS/disk surfaces vs Embree 3 discs on the scanned
# Stanford dragon (see bench/README.md).
#
# Full run (no arguments, or any bench_trace options except --quick):
#   docs/bench_trace.csv, docs/bench_trace.md, docs/bench_whole.png and
#   docs/bench_closeup.png (the largest size's MLS frames).
# Smoke test (--quick, sizes 2k and 32k): out/bench_trace_quick.{csv,md},
#   so that the measured tables in docs/ are not overwritten.
# Skips with exit 0 when Embree 3 or the dragon mesh is missing.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$root"
build="${SG_BENCH_BUILD_DIR:-build-bench}"

cmake -S . -B "$build" -DCMAKE_BUILD_TYPE=Release -DSG_BUILD_BENCH=ON >/dev/null
if ! cmake --build "$build" --target help | grep bench_trace >/dev/null; then
  echo "bench-trace: skipped: bench_trace is not built (Embree 3 not found; install libembree-dev)"
  exit 0
fi
cmake --build "$build" -j "$(nproc)" --target bench_trace

quick=0
for a in "$@"; do [ "$a" = "--quick" ] && quick=1; done
if [ "$quick" = 1 ]; then
  mkdir -p out
  exec "$build/bench/bench_trace" --csv out/bench_trace_quick.csv --md out/bench_trace_quick.md "$@"
fi
mkdir -p docs
exec "$build/bench/bench_trace" --csv docs/bench_trace.csv --md docs/bench_trace.md --png-dir docs "$@"
