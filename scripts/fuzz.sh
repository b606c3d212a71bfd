#!/usr/bin/env bash
# fuzz.sh — builds the libFuzzer harnesses of tests/fuzz (clang, ASan and
# UBSan, -DSG_FUZZ=ON) in build-fuzz/ and runs each one from its corpus.
#
#   scripts/fuzz.sh --smoke            CI: every harness for 5 s (.ci/run)
#   scripts/fuzz.sh --time 3600        the long run: an hour per harness
#   scripts/fuzz.sh --only ply --time 36000 --jobs 2
#
# Corpus: tests/fuzz/corpus/<format>/ (seeds from the test fixtures, kept
# in git) plus, when ../shared/data is there, its files of that format
# under 2 MB; what the fuzzer finds goes to build-fuzz/corpus/<format>/
# (kept between runs). A crash, leak, timeout (10 s an input) or memory
# blow-up (2 GB) leaves build-fuzz/artifacts/<format>-* and fails the run;
# reproduce with: build-fuzz/tests/fuzz/fuzz_<format> ARTIFACT.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$root"

seconds=5
only=""
jobs=1
while [ $# -gt 0 ]; do
  case "$1" in
    --smoke) seconds=5 ;;
    --time) seconds="$2"; shift ;;
    --only) only="$2"; shift ;;
    --jobs) jobs="$2"; shift ;;
    -h|--help) sed -n '2,17p' "$0"; exit 0 ;;
    *) echo "fuzz: unknown option $1 (see --help)" >&2; exit 1 ;;
  esac
  shift
done

command -v clang >/dev/null 2>&1 && command -v clang++ >/dev/null 2>&1 || {
  echo "fuzz: clang is not installed (scripts/setup.sh installs clang and libclang-rt-dev)" >&2; exit 1; }

mkdir -p build-fuzz
CC=clang CXX=clang++ cmake -S . -B build-fuzz -DCMAKE_BUILD_TYPE=RelWithDebInfo -DSG_FUZZ=ON \
  -DSG_BUILD_TESTS=OFF -DSG_BUILD_BENCH=OFF > build-fuzz/build.log 2>&1 || { cat build-fuzz/build.log; exit 1; }
cmake --build build-fuzz -j "$(nproc)" --target fuzz_all >> build-fuzz/build.log 2>&1 || { tail -40 build-fuzz/build.log; exit 1; }

# Extra seeds of each format from the shared data set, if it is there.
extras() {
  local ext="$1" data="$root/../shared/data"
  [ -d "$data" ] || return 0
  find "$data" -type f -iname "*.$ext" -size -2M 2>/dev/null | head -8
}

formats=(ply obj xyz pcd hdr exr scene sgbake sgworld)
failed=0
mkdir -p build-fuzz/artifacts
for f in "${formats[@]}"; do
  [ -z "$only" ] || [ "$only" = "$f" ] || continue
  work="build-fuzz/corpus/$f"
  mkdir -p "$work"
  case "$f" in scene) ext=json ;; *) ext="$f" ;; esac
  seeds=()
  while IFS= read -r s; do seeds+=("$s"); done < <(extras "$ext")
  mkdir -p "build-fuzz/seeds/$f"
  for s in "${seeds[@]+"${seeds[@]}"}"; do cp -f "$s" "build-fuzz/seeds/$f/"; done
  par=()
  [ "$jobs" -le 1 ] || par=(-jobs="$jobs" -workers="$jobs")
  echo "fuzz: $f for ${seconds} s"
  if ! "build-fuzz/tests/fuzz/fuzz_$f" -max_total_time="$seconds" -timeout=10 -rss_limit_mb=2048 \
      "${par[@]+"${par[@]}"}" -print_final_stats=1 -artifact_prefix="build-fuzz/artifacts/$f-" \
      "$work" "tests/fuzz/corpus/$f" "build-fuzz/seeds/$f" > "build-fuzz/$f.log" 2>&1; then
    tail -40 "build-fuzz/$f.log"
    echo "fuzz: $f FAILED; artifacts: $(ls build-fuzz/artifacts/"$f"-* 2>/dev/null | tr '\n' ' ')" >&2
    failed=1
  else
    grep -E "stat::number_of_executed_units|Done [0-9]+ runs" "build-fuzz/$f.log" | tail -1 || true
  fi
done
exit $failed
