#!/usr/bin/env bash
# verify.sh — builds splatgi-verify (Release) and runs the verification
# suite, then draws its charts (docs/verify.md explains every figure).
#
#   scripts/verify.sh                 the full run: docs/verify/*.csv, *.md,
#                                     *.png; difference images in
#                                     out/verify/diff. About 15-20 minutes on
#                                     2 shared cores the first time (the
#                                     converged references are cached in
#                                     out/verify/cache and reused after).
#   scripts/verify.sh --ci            the CI sweep (< 1 min) into out/verify-ci
#   scripts/verify.sh --parts scaling --sizes 2000000,4000000,8000000,16000000,24000000
#                                     the long scaling run (~25 min; 24M
#                                     points peaks at 13 GiB: docs/verify.md)
# Any other splatgi-verify option passes through (--help lists them).
# Exit: the verifier's (2: a stability case was flagged; charts are still drawn).
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$root"
build="${SG_VERIFY_BUILD_DIR:-build}"
jobs="${SG_JOBS:-2}"
cmake -S . -B "$build" -DCMAKE_BUILD_TYPE=Release >/dev/null
cmake --build "$build" -j "$jobs" --target splatgi-verify

out=docs/verify
diff=out/verify/diff
for a in "$@"; do
  if [ "$a" = "--ci" ]; then out=out/verify-ci; diff=out/verify-ci/diff; fi
  if [ "$a" = "--help" ]; then exec "$build/splatgi-verify" --help; fi
done
args=("$@")
for ((i = 0; i < ${#args[@]}; i++)); do
  [ "${args[$i]}" = "--out-dir" ] && [ $((i + 1)) -lt ${#args[@]} ] && out="${args[$((i + 1))]}"
done
rc=0
"$build/splatgi-verify" --out-dir "$out" --diff-dir "$diff" "$@" || rc=$?
if [ $rc -ne 0 ] && [ $rc -ne 2 ]; then exit $rc; fi
bash scripts/verify-charts.sh "$out" || { r=$?; [ $r -eq 77 ] || exit $r; }
exit $rc
