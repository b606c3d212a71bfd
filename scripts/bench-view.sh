#!/usr/bin/env bash
# bench-view.sh — builds bench_view (Release) and measures the walkthrough
# viewer's frame time (mean, p95) along a camera path on the Stanford
# dragon at 32k ... 4M points, 512x512 and 1024x768, diffuse and glossy
# bakes (see bench/README.md).
#
# Full run (no arguments, or any bench_view options except --quick):
#   docs/bench_view.csv, docs/bench_view.md; the path and scene files under
#   out/bench_view/. Minutes on 2 cores (world builds and bakes of the
#   large models dominate); pass --sizes to pick sizes.
# Smoke test (--quick: 32k points, every 6th key, < 1 min on quiet cores):
#   the same files under out/, so the tables in docs/ are not overwritten.
# Skips with exit 0 when the dragon mesh is missing.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$root"
build="${SG_BENCH_BUILD_DIR:-build-bench}"

cmake -S . -B "$build" -DCMAKE_BUILD_TYPE=Release -DSG_BUILD_BENCH=ON >/dev/null
cmake --build "$build" -j "$(nproc)" --target bench_view

outdir=docs
args=("$@")
for ((i = 0; i < ${#args[@]}; i++)); do
  case "${args[$i]}" in
    --quick) outdir=out ;;
    --help) exec "$build/bench/bench_view" --help ;;
  esac
done
for ((i = 0; i < ${#args[@]}; i++)); do
  if [ "${args[$i]}" = "--out-dir" ] && [ $((i + 1)) -lt ${#args[@]} ]; then
    outdir="${args[$((i + 1))]}"
  fi
done
mkdir -p "$outdir"
exec "$build/bench/bench_view" --out-dir "$outdir" "$@"
