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
. scripts/bench-lib.sh
bench_run bench_view "$@"
