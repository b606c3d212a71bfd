#!/usr/bin/env bash
# bench-ref.sh — builds bench_ref (Release), runs the reference path
# tracer's benchmark on the Stanford dragon under an HDR map, and draws the
# error-against-time chart with gnuplot (see bench/README.md).
#
# Full run (no arguments, or any bench_ref options except --quick):
#   docs/bench_ref.csv, docs/bench_ref.md, docs/ref_error_time.csv,
#   docs/ref_error_time.png, docs/bench_ref_reference.png. About 5 minutes
#   on 2 cores the first time (the converged reference takes most of it; it
#   is cached under out/ref_cache/ and reused), about 2 minutes after, on quiet cores.
# Smoke test (--quick: 125k points, small images, < 1 min): the same files
#   under out/, so the measured tables in docs/ are not overwritten.
# Skips with exit 0 when the dragon mesh is missing; draws no chart (and
# says so) when gnuplot is missing.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$root"
. scripts/bench-lib.sh
bench_run bench_ref "$@"

csv="$outdir/ref_error_time.csv"
png="$outdir/ref_error_time.png"
[ -f "$csv" ] || exit 0
if ! command -v gnuplot >/dev/null; then
  echo "bench-ref: gnuplot not found: no chart (install gnuplot-nox)"
  exit 0
fi
bench_term 960 640
# Columns of the CSV (bench_ref.c, write_curve_csv): 1 spp, 3 seconds,
# 4 rel_mse, 5 rel_mse_predicted, 10 ref_size, 11 ref_spp, 12 ideal_rel_mse,
# 13 ref_noise_rel_mse, 14 points, 17 envmap.
read -r points size refspp < <(awk -F, 'NR == 2 { print $14, $10, $11 }' "$csv")
envmap="$(awk -F, 'NR == 2 { print $17 }' "$csv")"
tmp="$png.tmp$$"
gnuplot <<GP
set terminal $term
set output "$tmp"
set datafile separator ","
set datafile missing ""
set logscale xy
set format x "10^{%L}"
set format y "10^{%L}"
set grid xtics ytics mxtics mytics lc rgb "#c8c8c8" dt 3
set xlabel "render time (s), $(nproc) cores"
set ylabel "relMSE against the converged reference"
set title "Reference path tracer: error against time\n{/*0.85 dragon $points points on the ground, ${envmap}, ${size}x${size} px; reference ${refspp} spp}"
set key top right box opaque
plot "$csv" skip 1 using 3:4 with linespoints lw 2 pt 7 ps 1.2 lc rgb "#1f6fb4" title "sg\\\\_ref\\\\_render, spp = 1, 2, 4, ...", \
     "" skip 1 using 3:4:(sprintf("%d", \$1)) with labels offset char 0,1.1 font ",9" notitle, \
     "" skip 1 using 3:5 with points pt 6 ps 1.6 lc rgb "#e07b00" title "predicted from the per-pixel standard errors", \
     "" skip 1 using 3:12 with lines dt 2 lw 2 lc rgb "#444444" title "ideal 1/t (median of relMSE x t)", \
     "" skip 1 using 3:13 with lines dt 3 lw 2 lc rgb "#b40000" title "the reference's own noise"
GP
mv "$tmp" "$png"
echo "bench-ref: wrote $png"
