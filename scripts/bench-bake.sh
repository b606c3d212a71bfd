#!/usr/bin/env bash
# bench-bake.sh — builds bench_bake (Release), runs the bake benchmark on the
# Stanford dragon under an HDR map, and draws the error-against-time chart
# with gnuplot (see bench/README.md).
#
# Full run (no arguments, or any bench_bake options except --quick):
#   docs/bench_bake.csv, docs/bench_bake.md, docs/bake_error_time.png. About
#   8 minutes on 2 quiet cores the first time (the two converged references
#   take 2.5 of them; they are cached under out/ref_cache/ and reused),
#   about 5.5 after; half as fast again when others share the cores.
# Smoke test (--quick: 32k points, small images, < 1 min): the same files
#   under out/, so the measured tables in docs/ are not overwritten.
# Skips with exit 0 when the dragon mesh is missing; draws no chart (and
# says so) when gnuplot is missing.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$root"
. scripts/bench-lib.sh
bench_run bench_bake "$@"

csv="$outdir/bench_bake.csv"
png="$outdir/bake_error_time.png"
[ -f "$csv" ] || exit 0
if ! command -v gnuplot >/dev/null; then
  echo "bench-bake: gnuplot not found: no chart (install gnuplot-nox)"
  exit 0
fi
bench_term 1100 800

# Columns of bench_bake.csv (bench_bake.c, write_csv): 1 kind, 2 points,
# 4 photons, 5 k, 6 direct, 7 spp, 8 width, 16 wall_s, 18 rel_mse.
# One data file per series, blocks separated by two blank lines, in
# (points, series) order; gnuplot plots them by index.
tmpd="$(mktemp -d)"
trap 'rm -rf "$tmpd"' EXIT
mapfile -t curve_sizes < <(awk -F, '$1 == "ref" { print $2 }' "$csv" | sort -nu)
[ ${#curve_sizes[@]} -gt 0 ] || { echo "bench-bake: no error rows in $csv: no chart"; exit 0; }
size="$(awk -F, '$1 == "ref" { print $8; exit }' "$csv")"
refspp="$(awk -F, '$1 == "ref" { print $29; exit }' "$csv")"
envmap="$(awk -F, '$1 == "ref" { print $(NF - 1); exit }' "$csv")"

colours=("#1f6fb4" "#d62728" "#2ca02c" "#9467bd")
plots=()
n=0
for ci in "${!curve_sizes[@]}"; do
  p="${curve_sizes[$ci]}"
  c="${colours[$((ci % ${#colours[@]}))]}"
  label="$(awk -v p="$p" 'BEGIN { if (p >= 1000000) printf "%gM", p / 1e6; else printf "%gk", p / 1e3 }')"
  # The reference renderer (centred curve): wall s, relMSE, spp.
  f="$tmpd/ref_$p.dat"
  awk -F, -v p="$p" '$1 == "ref" && $2 == p { print $16, $18, $7 }' "$csv" >"$f"
  plots+=("\"$f\" using 1:2 with linespoints lw 2 dt 2 pt 6 ps 1.3 lc rgb \"$c\" title \"reference renderer, $label points (spp 1, 2, 4, ...)\"")
  plots+=("\"$f\" using 1:2:(sprintf(\"%d\", \$3)) with labels offset char 0,-0.9 font \",8\" tc rgb \"$c\" notitle")
  # Bakes, photons carrying the direct light: one line per k.
  for k in $(awk -F, -v p="$p" '$1 == "bake" && $2 == p && $6 == -1 && $18 != "" { print $5 }' "$csv" | sort -nu); do
    f="$tmpd/bake_${p}_k$k.dat"
    awk -F, -v p="$p" -v k="$k" '$1 == "bake" && $2 == p && $5 == k && $6 == -1 && $18 != "" { print $4, $16, $18 }' "$csv" |
      sort -n >"$f"
    [ "$(wc -l <"$f")" -ge 2 ] || continue
    pt=$([ "$k" -le 64 ] && echo 7 || echo 5)
    span="$(awk 'function h(p) { return p >= 1e6 ? sprintf("%gM", p / 1e6) : sprintf("%gk", p / 1e3) }
                 NR == 1 { a = $1 } { b = $1 } END { print h(a) " ... " h(b) }' "$f")"
    plots+=("\"$f\" using 2:3 with linespoints lw 2 pt $pt ps 1.3 lc rgb \"$c\" title \"bake + frame, $label points, k $k, photons $span carrying direct light\"")
    if [ "$k" = "$(awk -F, -v p="$p" '$1 == "bake" && $2 == p && $6 == -1 && $18 != "" { print $5 }' "$csv" | sort -n | head -1)" ]; then
      plots+=("\"$f\" using 2:3:(\$1 >= 1e6 ? sprintf(\"%gM\", \$1 / 1e6) : sprintf(\"%gk\", \$1 / 1e3)) with labels offset char 0,1 font \",8\" tc rgb \"$c\" notitle")
    fi
  done
  # Bakes with the direct light by shadow rays (S samples per strategy).
  f="$tmpd/direct_$p.dat"
  # Column 6 of the data: 1 = every splat a sample point, 0 = sample points.
  awk -F, -v p="$p" '$1 == "bake" && $2 == p && $6 > 0 && $18 != "" { print $6, $16, $18, $5, $4, ($32 < 0) }' "$csv" | sort -n -k4,4 -k5,5 -k1,1 >"$f"
  if [ -s "$f" ]; then
    plots+=("\"$f\" using 2:3 with points pt 9 ps 1.8 lc rgb \"$c\" title \"bake + frame, $label points, k $(awk '{ print $4; exit }' "$f"), direct light by S shadow rays per sample point (sparse) or per splat (all), indirect by photons\"")
    plots+=("\"$f\" using 2:3:(sprintf(\"S %d %s, %gM\", \$1, \$6 > 0 ? \"all\" : \"sparse\", \$5 / 1e6)) with labels offset char 0,-0.9 font \",8\" tc rgb \"$c\" notitle")
  fi
  # The largest size: its reference renderer at the frame size (512x512),
  # spp x pixels / sg_ref_render's measured paths/s: the target's yardstick.
  if [ "$ci" -eq $((${#curve_sizes[@]} - 1)) ]; then
    f="$tmpd/ref_big_$p.dat"
    awk -F, -v p="$p" '$1 == "ref_render" && $2 == p { fw = $9; ps = $28 }
      $1 == "ref" && $2 == p { spp[++n] = $7; err[n] = $18 }
      END { if (ps > 0) for (i = 1; i <= n; i++) print spp[i] * fw * fw / ps, err[i], spp[i], fw }' "$csv" >"$f"
    if [ -s "$f" ]; then
      fw="$(awk '{ print $4; exit }' "$f")"
      plots+=("\"$f\" using 1:2 with linespoints lw 1.5 dt 3 pt 4 ps 1 lc rgb \"$c\" title \"reference renderer, $label points, one ${fw}x${fw} frame (spp x ${fw}^2 / sg\\\\_ref\\\\_render's paths/s)\"")
    fi
  fi
  n=$((n + 1))
done
# bench_ref's curve (sg_ref_render, jittered, against its jittered
# reference) when it is the same view at the same size: a check.
if [ -f docs/ref_error_time.csv ]; then
  f="$tmpd/bench_ref.dat"
  awk -F, -v s="$size" 'NR > 1 && $10 == s { print $3, $4, $14 }' docs/ref_error_time.csv >"$f"
  if [ -s "$f" ] && [ "$(awk '{ print $3; exit }' "$f")" = "${curve_sizes[0]}" ]; then
    plots+=("\"$f\" using 1:2 with lines lw 1 dt 3 lc rgb \"#555555\" title \"bench\\\\_ref: sg\\\\_ref\\\\_render (jittered), ${curve_sizes[0]} points\"")
  fi
fi
target=0.01
# Ranges: every point and the target line, with a margin (log axes).
read -r xlo xhi ylo yhi < <(awk -F, -v t="$target" '
  NR == FNR { if ($1 == "ref_render") big[$2] = $9 * $9 / $28; next }
  ($1 == "ref" || ($1 == "bake" && $18 != "")) && $16 > 0 {
    x = $16; y = $18
    if ($1 == "ref" && ($2 in big) && $7 * big[$2] > xhi) xhi = $7 * big[$2]
    if (xlo == "" || x < xlo) xlo = x
    if (x > xhi) xhi = x
    if (ylo == "" || y < ylo) ylo = y
    if (y > yhi) yhi = y
  }
  END { if (t < ylo) ylo = t; printf "%g %g %g %g\n", xlo / 1.6, xhi * 1.6, ylo / 1.6, yhi * 8 }' "$csv" "$csv")
# What a frame at the frame size adds to a bake point, for the axis label.
fwb="$(awk -F, '$1 == "bake" { print $9; exit }' "$csv")"
extra="$(awk -F, '$1 == "bake" && $18 != "" { d = $14 - $13; if (lo == "" || d < lo) lo = d; if (d > hi) hi = d }
  END { printf "%.2f-%.2f", lo, hi }' "$csv")"
plot_cmd="$(IFS=,; echo "${plots[*]}")"
tmp="$png.tmp$$"
gnuplot <<GP
set terminal $term
set output "$tmp"
set logscale xy
set xrange [$xlo:$xhi]
set yrange [$ylo:$yhi]
set format x "10^{%L}"
set format y "10^{%L}"
set grid xtics ytics mxtics mytics lc rgb "#c8c8c8" dt 3
set xlabel "wall time (s), $(nproc) cores: bake (trace + gather) + one ${size}x${size} lookup frame (a ${fwb}x${fwb} one adds ${extra} s); reference: one render"
set ylabel "relMSE against the converged reference (pixel centres)"
set title "The bake against the reference path tracer: error against time\n{/*0.85 dragon on the ground, ${envmap}, ${size}x${size} px; reference ${refspp} spp at pixel centres}"
set key inside top right box opaque font ",9" spacing 1.1 samplen 3
set arrow from graph 0, first $target to graph 1, first $target nohead lw 1.5 dt 4 lc rgb "#b40000"
set label "relMSE $target (the issue's target)" at graph 0.01, first $target offset 0,0.6 font ",9" tc rgb "#b40000"
plot $plot_cmd
GP
mv "$tmp" "$png"
echo "bench-bake: wrote $png"
