#!/usr/bin/env bash
# bench_mpi.sh — the distributed bake (docs/mpi.md) on this machine.
#
#   bench/bench_mpi.sh scaling [--points N] [--build DIR] [--out-dir DIR]
#     strong scaling of one bake: a plain run with 2 threads, then mpirun
#     -np 1 x 2 threads and -np 2 x 1 thread, side by side in one run, on
#     the Stanford dragon sampled to N points (default 250000) on its
#     ground, from a world file built once (splatgi-world), so only the
#     bake is compared; every .sgbake is cmp'd with the plain one. Wall
#     time of the bake ("bake X s in this run" of splatgi-bake's report),
#     of the whole command, and the peak RSS of each process
#     (/usr/bin/time -v); then the photon estimator (1M photons) plainly
#     and on 2 ranks.
#   bench/bench_mpi.sh memory [--sizes 250000,1000000,4000000] [...]
#     peak RSS of a plain splatgi-bake (world built in the process, then
#     the default transport bake, 2 threads) at each size, to extrapolate
#     the largest bake that fits in a machine's memory.
#
# Prints the machine first; appends rows to OUT/bench_mpi_scaling.csv or
# OUT/bench_mpi_memory.csv (OUT: --out-dir, default docs) and prints them.
# Needs an MPI build of splatgi-bake (cmake -DSG_MPI=ON, the default when
# libopenmpi-dev is installed) for scaling; memory needs none.
set -euo pipefail

root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
mode="${1:-}"
[ -n "$mode" ] && shift
points=250000 sizes=250000,1000000,4000000 build="$root/build" outdir="$root/docs"
while [ $# -gt 0 ]; do
  case "$1" in
    --points) points="$2"; shift 2 ;;
    --sizes) sizes="$2"; shift 2 ;;
    --build) build="$2"; shift 2 ;;
    --out-dir) outdir="$2"; shift 2 ;;
    *) echo "bench_mpi.sh: unknown option '$1'" >&2; exit 1 ;;
  esac
done
case "$mode" in
  scaling|memory) ;;
  *) sed -n '2,20p' "${BASH_SOURCE[0]}" | sed 's/^# \{0,1\}//'; exit 1 ;;
esac

bake="$build/splatgi-bake" world="$build/splatgi-world"
mesh="$root/../shared/data/meshes/stanford_dragon/dragon_vrip.ply"
[ -x "$bake" ] || { echo "bench_mpi.sh: no $bake (build first)" >&2; exit 1; }
[ -r "$mesh" ] || { echo "skipped: $mesh not found"; exit 0; }
mkdir -p "$outdir"
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
if [ "$(id -u)" -eq 0 ]; then
  export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
fi

# The machine.
cpu="$(lscpu | sed -n 's/^Model name: *//p' | head -1)"
mem_gib="$(awk '/MemTotal/ {printf "%.1f", $2 / 1048576}' /proc/meminfo)"
echo "machine: $cpu, $(nproc) cores, $mem_gib GiB, $(uname -sr), load $(cut -d' ' -f1-3 /proc/loadavg)"
echo "mpirun:  $(mpirun --version 2>/dev/null | head -1 || echo none)"
echo "commit:  $(git -C "$root" rev-parse --short HEAD 2>/dev/null || echo unknown)"

now() { date +%s.%N; }
# Peak RSS in MiB of every process whose /usr/bin/time -v report is in $1.
rss_of() { awk '/Maximum resident set size/ {printf "%s%.0f", sep, $6 / 1024; sep = "/"}' "$1"; }
bake_s() { sed -n 's/.*bake \([0-9.]*\) s in this run.*/\1/p' "$1"; }

if [ "$mode" = memory ]; then
  csv="$outdir/bench_mpi_memory.csv"
  [ -s "$csv" ] || echo "points,splats,world_s,bake_s,total_s,peak_rss_mib,bake_mib,machine" > "$csv"
  for n in ${sizes//,/ }; do
    t0=$(now)
    /usr/bin/time -v "$bake" "$mesh" --points "$n" -o "$work/m$n.sgbake" --threads 2 > "$work/m$n.log" 2> "$work/m$n.err" ||
      { cat "$work/m$n.log" "$work/m$n.err"; exit 1; }
    t1=$(now)
    splats=$(sed -n 's/.*, \([0-9]*\) splats, world built in \([0-9.]*\) s/\1/p' "$work/m$n.log")
    wsec=$(sed -n 's/.*world built in \([0-9.]*\) s/\1/p' "$work/m$n.log")
    bmib=$(sed -n 's/^  bake memory *\([0-9.]*\) MiB/\1/p' "$work/m$n.log")
    row="$n,$splats,$wsec,$(bake_s "$work/m$n.log"),$(echo "$t1 - $t0" | bc),$(rss_of "$work/m$n.err"),$bmib,\"$cpu, $(nproc) cores\""
    echo "$row" >> "$csv"
    echo "$row"
  done
  exit 0
fi

# scaling
csv="$outdir/bench_mpi_scaling.csv"
[ -s "$csv" ] || echo "points,splats,run,ranks,threads,bake_s,wall_s,peak_rss_mib,identical,machine" > "$csv"
"$world" "$mesh" --points "$points" -o "$work/w.sgworld" > "$work/world.log" 2>&1 || { cat "$work/world.log"; exit 1; }
run() { # label ranks threads command...
  local label=$1 ranks=$2 threads=$3
  shift 3
  local t0 t1
  t0=$(now)
  "$@" > "$work/$label.log" 2> "$work/$label.err" || { cat "$work/$label.log" "$work/$label.err"; exit 1; }
  t1=$(now)
  local same=reference
  case "$label" in
    plain*) ;;
    *) cmp -s "$work/plain.sgbake" "$work/$label.sgbake" && same=yes || same=NO ;;
  esac
  local splats
  splats=$(sed -n 's/.*, \([0-9]*\) splats, world built.*/\1/p' "$work/$label.log")
  local row="$points,$splats,$label,$ranks,$threads,$(bake_s "$work/$label.log"),$(echo "$t1 - $t0" | bc),$(rss_of "$work/$label.err"),$same,\"$cpu, $(nproc) cores\""
  echo "$row" >> "$csv"
  echo "$row"
}
common=("$mesh" --points "$points" --world "$work/w.sgworld")
echo "points,splats,run,ranks,threads,bake_s,wall_s,peak_rss_mib,identical,machine"
run plain 1 2 /usr/bin/time -v "$bake" "${common[@]}" -o "$work/plain.sgbake" --threads 2
run np1x2 1 2 mpirun -np 1 /usr/bin/time -v "$bake" "${common[@]}" -o "$work/np1x2.sgbake" --threads 2
run np2x1 2 1 mpirun --oversubscribe -np 2 /usr/bin/time -v "$bake" "${common[@]}" -o "$work/np2x1.sgbake" --threads 1
# The photon estimator: 1M photons in 245 blocks of 4096, divided by blocks.
pcommon=("${common[@]}" --indirect photons --photons 1000000)
run plain-photons 1 2 /usr/bin/time -v "$bake" "${pcommon[@]}" -o "$work/plain-photons.sgbake" --threads 2
cp "$work/plain.sgbake" "$work/plain-transport.sgbake" && cp "$work/plain-photons.sgbake" "$work/plain.sgbake"
run np2x1-photons 2 1 mpirun --oversubscribe -np 2 /usr/bin/time -v "$bake" "${pcommon[@]}" -o "$work/np2x1-photons.sgbake" --threads 1
grep -h "photons  " "$work/plain-photons.log" "$work/np2x1-photons.log"
grep -h "sample sites\|sample points  \|distributed  \|not divisible\|total  " "$work/plain.log" "$work/np2x1.log"
