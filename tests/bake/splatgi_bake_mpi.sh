#!/bin/sh
# splatgi_bake_mpi.sh — the distributed bake end to end (docs/mpi.md):
#  1. byte equality: a plain bake (no mpirun) against mpirun -np 1, 2 and 3
#     with 1 or 2 OpenMP threads per rank, for a scene with a glossy model
#     (sample sites, the transport solve and glossy bins) and with the
#     photon estimator (photon blocks); cmp of the .sgbake files;
#  2. a failed rank: rank 1's third exchange fails (SPLATGI_MPI_FAULT=
#     1:3:error) -> nonzero exit, a message naming rank 1, no OUT for a new
#     path, an existing OUT unchanged, no temporary file left;
#  3. a killed rank: rank 1 kills itself with SIGKILL mid-bake (1:4:kill)
#     -> nonzero exit, mpirun names the rank, OUT unchanged, nothing left;
#  4. an interrupt reaching rank 1 alone (SPLATGI_MPI_FAULT=1:2:int) ->
#     all ranks stop at the same round, rank 0 writes OUT.ckpt, no OUT;
#     --resume on 3 ranks and plainly give the plain bake's bytes;
#  5. Ctrl-C: SIGINT to mpirun while 2 ranks trace -> the message at once,
#     no OUT and no partial file; OUT.ckpt when the ranks reach a round's
#     end before mpirun's SIGKILL (nearly always), and then --resume on 3
#     ranks equals the run straight through.
# usage: splatgi_bake_mpi.sh SPLATGI_BAKE MPIRUN WORKDIR
# Exit 77 (ctest: skipped) only if the interrupted run of 5 finished before
# the signal came, which leaves the resume unchecked.
set -u
BAKE=$1 MPIRUN=$2 DIR=$3
rm -rf "$DIR" && mkdir -p "$DIR" || exit 1
cd "$DIR" || exit 1
fail() { echo "FAIL: $*" >&2; exit 1; }

# Open MPI refuses root without these (CI containers run as root).
if [ "$(id -u)" -eq 0 ]; then
    export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
fi
# One machine of 2 cores: more ranks than cores, and no network probing.
# A run that hangs (ranks disagreeing about a round) fails here after a
# minute, with status 124, instead of at ctest's timeout.
mpi() { timeout 60 "$MPIRUN" --oversubscribe --mca btl self,vader -np "$@"; }

cat > scene.json <<'JSON'
{ "models": [ { "builtin": "sphere", "points": 3000, "transform": { "translate": [0, 1, 0] },
                "material": { "type": "ggx", "roughness": 0.4 } },
              { "builtin": "ground", "points": 4000 } ],
  "envmap": { "builtin": "sky" },
  "cameras": [ { "name": "main", "eye": [0, 2.5, 4], "look": [0, 0.8, 0] } ],
  "render": { "width": 64, "height": 64 } }
JSON
T="--direct 16 --gather-rays 32 --glossy-rays 32"
P="--indirect photons --photons 300000 --direct 8 --gather-rays 8"

# 1. Byte equality with the plain bake.
"$BAKE" scene.json -o plain.sgbake $T --threads 2 > plain.log 2>&1 || { cat plain.log; fail "plain bake"; }
grep -q "glossy bins  *[1-9]" plain.log || { cat plain.log; fail "the scene made no glossy bins"; }
for run in "1 2" "2 1" "3 1" "2 2"; do
    set -- $run
    mpi "$1" "$BAKE" scene.json -o "np$1t$2.sgbake" $T --threads "$2" > "np$1t$2.log" 2>&1 ||
        { cat "np$1t$2.log"; fail "mpirun -np $1 (threads $2)"; }
    grep -q "distributed over $1 rank" "np$1t$2.log" || { cat "np$1t$2.log"; fail "np $1 did not distribute"; }
    cmp plain.sgbake "np$1t$2.sgbake" || fail "np $1 x $2 threads differs from the plain bake"
done
"$BAKE" scene.json -o photons.sgbake $P --threads 2 > photons.log 2>&1 || { cat photons.log; fail "plain photons"; }
for n in 2 3; do
    mpi "$n" "$BAKE" scene.json -o "photons$n.sgbake" $P --threads 1 > "photons$n.log" 2>&1 ||
        { cat "photons$n.log"; fail "photons on $n ranks"; }
    cmp photons.sgbake "photons$n.sgbake" || fail "the photon estimator on $n ranks differs from the plain bake"
done
# Progress and the report come from rank 0 alone.
[ "$(grep -c "^splatgi-bake: scene.json -> " np3t1.log)" -eq 1 ] || { cat np3t1.log; fail "report not once"; }

# 2. A rank that fails: the job ends, nothing is written.
echo "an older bake" > keep.sgbake
cp keep.sgbake keep.orig
for out in new.sgbake keep.sgbake; do
    SPLATGI_MPI_FAULT=1:3:error mpi 2 "$BAKE" scene.json -o $out $T --threads 1 > fault.log 2>&1 &&
        fail "a failed rank exited 0 ($out)"
    grep -q "^splatgi-bake: rank 1: MPI: exchange 3 failed" fault.log || { cat fault.log; fail "no message naming rank 1"; }
    [ ! -e new.sgbake ] || fail "a failed job wrote new.sgbake"
    cmp keep.sgbake keep.orig || fail "a failed job changed an existing OUT"
done

# 3. A rank killed mid-bake (SIGKILL: no handler runs on it).
SPLATGI_MPI_FAULT=1:4:kill mpi 3 "$BAKE" scene.json -o keep.sgbake $T --threads 1 > kill.log 2>&1 &&
    fail "a killed rank's job exited 0"
grep -q "rank 1 .*signal 9" kill.log || { cat kill.log; fail "mpirun did not name the killed rank"; }
cmp keep.sgbake keep.orig || fail "a killed job changed an existing OUT"
ls | grep -q "\.tmp\." && { ls; fail "a temporary file was left"; }
SPLATGI_MPI_FAULT=1:x:kill "$BAKE" scene.json -o bad.sgbake > badf.log 2>&1 && fail "a bad SPLATGI_MPI_FAULT accepted"
grep -q "SPLATGI_MPI_FAULT='1:x:kill' is not" badf.log || { cat badf.log; fail "message for a bad fault"; }

# 4. Ctrl-C reaching rank 1 alone (SPLATGI_MPI_FAULT=1:2:int): every rank
#    stops at the same round, rank 0 writes OUT.ckpt and no OUT; --resume
#    on 3 ranks, then plainly, gives the plain bake's bytes.
SPLATGI_MPI_FAULT=1:2:int mpi 2 "$BAKE" scene.json -o cut.sgbake $T --threads 1 > cut.log 2>&1 &&
    { cat cut.log; fail "an interrupted job exited 0"; }
[ -s cut.sgbake.ckpt ] || { cat cut.log; fail "no checkpoint after an interrupt on rank 1"; }
[ ! -e cut.sgbake ] || fail "an interrupted job wrote its output"
[ "$(grep -c "interrupted at" cut.log)" -eq 1 ] || { cat cut.log; fail "not one 'interrupted' line (rank 0's)"; }
cp cut.sgbake.ckpt cut.ckpt.orig
mpi 3 "$BAKE" scene.json -o cut.sgbake $T --threads 1 --resume > res.log 2>&1 || { cat res.log; fail "resume on 3 ranks"; }
grep -q "resuming from" res.log || { cat res.log; fail "did not resume"; }
[ ! -e cut.sgbake.ckpt ] || fail "the checkpoint was left after the resumed bake"
cmp plain.sgbake cut.sgbake || fail "the bake resumed on 3 ranks differs from the plain one"
cp cut.ckpt.orig cut2.sgbake.ckpt
"$BAKE" scene.json -o cut2.sgbake $T --threads 2 --resume > res2.log 2>&1 || { cat res2.log; fail "plain resume"; }
cmp plain.sgbake cut2.sgbake || fail "a distributed checkpoint resumed plainly differs from the plain bake"
grep "interrupted at" cut.log

# 5. A real Ctrl-C: SIGINT to mpirun while 2 ranks trace. mpirun waits a
#    second (odls_base_sigkill_timeout), sends the ranks SIGTERM, and kills
#    them a second later: they agree to stop at their next round (rounds
#    are well under a second), rank 0 writes OUT.ckpt, no OUT; --resume on
#    3 ranks equals the run straight through. One level of sample points
#    with many rays, so the signal lands among the rounds.
#    The bake must outlast mpirun's second of delay: at 2048 + 4096 rays it
#    took 1.2 s and a loaded machine saw it finish before the ranks heard
#    of the signal; 4x the rays keeps it tracing for several seconds.
R="--direct 8192 --gather-rays 16384 --refine 0 --glossy-rays 16"
mpi 2 "$BAKE" scene.json -o full.sgbake $R --threads 1 > full.log 2>&1 || { cat full.log; fail "full bake"; }
# mpirun itself in the background (not the mpi function, whose subshell
# would take the signal), so that $! is mpirun's pid.
"$MPIRUN" --oversubscribe --mca btl self,vader -np 2 "$BAKE" scene.json -o int.sgbake $R --threads 1 > int.log 2>&1 &
pid=$!
i=0
until grep -q "estimator:" int.log 2>/dev/null; do
    i=$((i + 1)); [ $i -lt 600 ] || fail "the bake never started"; sleep 0.05
done
sleep 0.2
kill -INT $pid
wait $pid
rc=$?
if [ $rc -eq 0 ]; then echo "the bake finished before SIGINT; resume not checked"; exit 77; fi
grep -q "interrupted: stopping after this block of work" int.log || { cat int.log; fail "no message for Ctrl-C"; }
ls | grep -q "^int\.sgbake\.tmp\." && { ls; fail "a partial output was left"; }
if [ -e int.sgbake ]; then
    # The ranks had finished every round when the signal reached them
    # (mpirun forwards it a second late): then the output is the whole
    # bake, never a partial one.
    cmp full.sgbake int.sgbake || fail "an interrupted job wrote an output that is not the whole bake"
    echo "the bake completed before the ranks heard of SIGINT (exit $rc); resume not checked"
    exit 77
fi
if [ -s int.sgbake.ckpt ]; then
    mpi 3 "$BAKE" scene.json -o int.sgbake $R --threads 1 --resume > res3.log 2>&1 || { cat res3.log; fail "resume"; }
    cmp full.sgbake int.sgbake || fail "the bake resumed after Ctrl-C differs from the one straight through"
    grep "interrupted at" int.log
else
    # The SIGKILL that follows a second after mpirun's SIGTERM came while
    # the ranks were in a step that is not interruptible (the solve):
    # documented (docs/mpi.md); part 4 checks the checkpoint path.
    echo "note: mpirun killed the ranks before the checkpoint (exit $rc); no output written"
fi
echo "ok"
