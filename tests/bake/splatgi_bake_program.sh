#!/bin/sh
# splatgi_bake_program.sh — runs the splatgi-bake program end to end on a
# small scene: a bake, a frame rendered from it (splatgi-render --bake),
# the error paths (a bake for another scene, --resume with nothing to
# resume), and Ctrl-C: SIGINT while the sample sites' rays are traced (and,
# with --indirect photons, while photons are) must leave OUT.ckpt and exit
# 130, --resume must finish it, remove the checkpoint and write the same
# bytes (cmp) as a run straight through.
# usage: splatgi_bake_program.sh SPLATGI_BAKE SPLATGI_RENDER WORKDIR
# Exit 77 (ctest: skipped) only if the interrupted run finished before the
# signal came, which leaves the resume unchecked.
set -u
BAKE=$1 RENDER=$2 DIR=$3
rm -rf "$DIR" && mkdir -p "$DIR" || exit 1
cd "$DIR" || exit 1
fail() { echo "FAIL: $*" >&2; exit 1; }

cat > scene.json <<'JSON'
{ "models": [ { "builtin": "sphere", "points": 8000, "transform": { "translate": [0, 1, 0] } },
              { "builtin": "ground", "points": 8000 } ],
  "envmap": { "builtin": "sky" },
  "cameras": [ { "name": "main", "eye": [0, 2.5, 4], "look": [0, 0.8, 0] } ],
  "render": { "width": 96, "height": 96 } }
JSON
sed 's/"sky"/"studio"/' scene.json > other.json

# 1. A bake, and a frame from it.
"$BAKE" scene.json -o a.sgbake --direct 16 --gather-rays 32 --threads 2 > a.log 2>&1 || { cat a.log; fail "bake"; }
[ -s a.sgbake ] || fail "no a.sgbake"
[ ! -e a.sgbake.ckpt ] || fail "a checkpoint was left after a finished bake"
grep -q "bake memory" a.log || { cat a.log; fail "no memory report"; }
"$RENDER" --scene scene.json --bake a.sgbake --camera main --out a.png > r.log 2>&1 || { cat r.log; fail "render"; }
[ -s a.png ] || fail "no a.png"
grep -q "frame" r.log || fail "no frame time"

# 2. Errors: a bake for another scene; nothing to resume; a bad option.
"$RENDER" --scene other.json --bake a.sgbake --out b.png > r2.log 2>&1 && fail "rendered another scene's bake"
grep -q "a.sgbake: made for another scene" r2.log || { cat r2.log; fail "message for another scene"; }
"$BAKE" scene.json -o none.sgbake --resume > n.log 2>&1
[ $? -eq 1 ] || fail "--resume without a checkpoint should exit 1"
grep -q "^splatgi-bake: none.sgbake.ckpt: no checkpoint to resume" n.log || { cat n.log; fail "message"; }
"$BAKE" scene.json --photons 0 > z.log 2>&1 && fail "--photons 0 accepted"
grep -q "^splatgi-bake: --photons: '0' is not an integer" z.log || { cat z.log; fail "message"; }

# 3. Ctrl-C and --resume against a run straight through, for each
#    estimator: $1 options, $2 the line that says the work has begun.
interrupt_and_resume() {
    opts=$1 tag=$2
    rm -f full.sgbake cut.sgbake cut.sgbake.ckpt
    "$BAKE" scene.json -o full.sgbake $opts --threads 2 > full.log 2>&1 || { cat full.log; fail "full bake ($tag)"; }
    "$BAKE" scene.json -o cut.sgbake $opts --threads 2 > cut.log 2>&1 &
    pid=$!
    i=0
    until grep -q "estimator:" cut.log 2>/dev/null; do   # the job has begun
        i=$((i + 1)); [ $i -lt 600 ] || fail "the bake never started ($tag)"; sleep 0.05
    done
    sleep 0.4
    kill -INT $pid
    wait $pid
    rc=$?
    if [ $rc -eq 0 ]; then echo "the bake finished before SIGINT; resume not checked ($tag)"; exit 77; fi
    [ $rc -eq 130 ] || { cat cut.log; fail "interrupted bake exited $rc, expected 130 ($tag)"; }
    [ -s cut.sgbake.ckpt ] || fail "no checkpoint ($tag)"
    [ ! -e cut.sgbake ] || fail "an interrupted bake wrote its output ($tag)"
    grep -q "to resume: .* --resume" cut.log || { cat cut.log; fail "no resume hint ($tag)"; }
    "$BAKE" scene.json -o cut.sgbake $opts --seed 99 --threads 2 --resume > bad.log 2>&1 &&
        fail "resumed with other options ($tag)"
    grep -q "made with other bake parameters" bad.log || { cat bad.log; fail "message for other options ($tag)"; }
    "$BAKE" scene.json -o cut.sgbake $opts --threads 1 --resume > res.log 2>&1 || { cat res.log; fail "resume ($tag)"; }
    grep -q "resuming from" res.log || { cat res.log; fail "did not resume ($tag)"; }
    [ ! -e cut.sgbake.ckpt ] || fail "the checkpoint was left after the resumed bake ($tag)"
    cmp full.sgbake cut.sgbake || fail "resumed bake differs from the one straight through ($tag)"
    grep "interrupted at" cut.log
}
interrupt_and_resume "--direct 256 --gather-rays 512 --refine 1" "transport"
interrupt_and_resume "--indirect photons --photons 1500000" "photons"
echo "ok"
