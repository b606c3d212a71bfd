#!/usr/bin/env bash
# verify-charts.sh DIR — draws the verification suite's charts from the CSV
# that splatgi-verify wrote into DIR, into DIR:
#   verify_surfaces.png   frame time against error per surface model/option
#   verify_bake.png       bake time against error, both indirect estimators
#   verify_gi.png         CPU time against error on concave close-ups (log-log)
#   verify_scaling.png    fps, memory, per-ray traversal, times against model
#                         size, per surface model
#   verify_stability.png  the stability map as a heat-map table
#   verify_hybrid_lod.png the hybrid hierarchy's level-of-detail threshold as
#                         a speed-against-error curve (Ye 2005 fig. 11), from
#                         bench_hybrid's CSV: DIR/hybrid.csv, else
#                         DIR/../bench_hybrid.csv (docs/bench_hybrid.csv)
# The surface models and their colours are the table below (names as in the
# CSVs, src/verify/verify_int.h): a new model is one more line.
# A chart whose CSV is absent is skipped. Exit 77 when gnuplot is missing.
set -euo pipefail
dir="${1:?usage: verify-charts.sh DIR}"
command -v gnuplot >/dev/null || { echo "verify-charts: gnuplot not found (install gnuplot-nox)"; exit 77; }
if gnuplot -e 'set terminal pngcairo' >/dev/null 2>&1; then
  term() { echo "pngcairo size $1,$2 enhanced font \"sans,10\""; }
else
  term() { echo "png size $1,$2"; }
fi
models=(mls disk iso)
model_title=(MLS disks ISO)
model_colour=("#1f6fb4" "#d62728" "#2ca02c")
model_pt=(7 5 9)
model_label=("0,0.8" "0,-0.8" "0,1.6") # label offsets (characters) of each model's points
tmpd="$(mktemp -d)"
trap 'rm -rf "$tmpd"' EXIT
# Writes gnuplot's output to a temporary name, then renames it.
plot() { # plot OUT.png < script
  local out="$1" tmp="$1.tmp$$.png"
  { echo "set output \"$tmp\""; cat; } | gnuplot
  mv "$tmp" "$out"
  echo "verify-charts: wrote $out"
}

# ---- 1. surfaces: frame time against error --------------------------------
csv="$dir/surfaces.csv"
if [ -f "$csv" ]; then
  # columns: 1 config, 2 model, 7 renderer, 10 frame_s, 12 frame_size, 13 rel_mse, 17 nodes/ray, 20 splats/ray
  sb=() sd=()
  for i in "${!models[@]}"; do
    m="${models[$i]}" c="${model_colour[$i]}" pt="${model_pt[$i]}" t="${model_title[$i]}"
    off="${model_label[$i]}"
    awk -F, -v m="$m" 'NR > 1 && $7 == "bake_lookup" && $2 == m { print $10 * 1000, $13, $1 }' "$csv" >"$tmpd/sb_$m"
    # the first MLS row's direct frame is the yardstick (0): left out
    awk -F, -v m="$m" 'NR > 1 && $7 == "direct" && $2 == m && !(m == "mls" && $1 == "mls") { print $10 * 1000, $13, $1 }' \
      "$csv" >"$tmpd/sd_$m"
    if [ -s "$tmpd/sb_$m" ]; then
      sb+=("\"$tmpd/sb_$m\" u 1:2 w p pt $pt ps 1.5 lc rgb \"$c\" t \"$t\"")
      sb+=("\"$tmpd/sb_$m\" u 1:2:3 w labels offset char $off font \",8\" tc rgb \"$c\" notitle")
    fi
    if [ -s "$tmpd/sd_$m" ]; then
      [ "$m" = mls ] && t="MLS options"
      sd+=("\"$tmpd/sd_$m\" u 1:(\$2 > 0 ? \$2 : 1e-6) w p pt $pt ps 1.5 lc rgb \"$c\" t \"$t\"")
      sd+=("\"$tmpd/sd_$m\" u 1:(\$2 > 0 ? \$2 : 1e-6):3 w labels offset char $off font \",8\" tc rgb \"$c\" notitle")
    fi
  done
  fs="$(awk -F, 'NR == 2 { print $12 }' "$csv")"
  pts="$(awk -F, 'NR == 2 { print $6 }' "$csv")"
  plot "$dir/verify_surfaces.png" <<GP
set terminal $(term 1400 620)
set termoption noenhanced
set multiplot layout 1,2 title "Surface models: frame time against error ($pts splats, ${fs}x${fs} frames, best of 2)"
set logscale y
set grid lc rgb "#cccccc"
set key top left box opaque font ",9"
set xlabel "bake lookup frame time (ms)"
set ylabel "relMSE against the converged reference of the default MLS surface"
set title "bake + lookup (global illumination)"
plot $(IFS=,; echo "${sb[*]}")
set xlabel "direct renderer frame time (ms), SG_SHADE_SIMPLE, model only"
set ylabel "relMSE against the default MLS surface's direct frame (the yardstick, 0)"
set title "direct renderer (geometry only)"
plot $(IFS=,; echo "${sd[*]}")
unset multiplot
GP
fi

# ---- 2. bake: bake time against error ---------------------------------------
csv="$dir/bake.csv"
if [ -f "$csv" ]; then
  # columns: 1 sweep, 2 photons, 3 k, 4 direct, 9 bake_s, 14 rel_mse, 19 spacing,
  # 20 sample points, 21 glossy, 22 glossy_res, 23 glossy_rays, 24 estimator, 25 gather_rays
  plots=()
  colours=("#1f6fb4" "#17becf" "#d62728" "#ff7f0e" "#8c564b" "#9467bd" "#e377c2")
  i=0
  for sw in transport_rays transport_spacing photons photons_carry_direct k glossy_res glossy_rays; do
    f="$tmpd/b_$sw"
    awk -F, -v s="$sw" 'NR > 1 && $1 == s {
        if (s == "transport_rays") lab = $4 "+" $25
        else if (s == "transport_spacing") lab = ($19 < 0 ? "all" : sprintf("s=%g", $19))
        else if (s ~ /^photons/) lab = ($2 >= 1e6 ? sprintf("%gM", $2 / 1e6) : sprintf("%gk", $2 / 1e3))
        else if (s == "k") lab = "k=" $3
        else if (s == "glossy_res") lab = ($22 == 0 ? "R=auto" : "R=" $22)
        else lab = "M=" $23
        print $9, $14, lab }' "$csv" | sort -n >"$f"
    [ -s "$f" ] || continue
    c="${colours[$i]}"
    case "$sw" in
      transport_rays) t="transport (default): envmap + cosine rays per sample site";;
      transport_spacing) t="transport: sample spacing (x median splat radius; default 4 is 32+64)";;
      photons) t="photons (first estimator): photon count, k 64, direct by 16 + 32 rays per site";;
      photons_carry_direct) t="photons: photon count, photons carry the direct light too";;
      k) t="photons: gather k ($(awk -F, 'NR > 1 && $1 == "k" { printf "%gk photons", $2 / 1000; exit }' "$csv"))";;
      glossy_res) t="glossy model (GGX, roughness 0.3): bins per side R (auto = 27), own reference";;
      glossy_rays) t="glossy model: rays per glossy sample point M (default 128 = R=auto)";;
    esac
    lt=$([ "${sw#photons}" != "$sw" ] || [ "$sw" = "k" ] && echo "dt 2" || echo "dt 1")
    plots+=("\"$f\" u 1:2 w linespoints lw 2 $lt pt 7 ps 1.3 lc rgb \"$c\" t \"$t\"")
    plots+=("\"$f\" u 1:2:3 w labels offset char 0,0.9 font \",8\" tc rgb \"$c\" notitle")
    i=$((i + 1))
  done
  pts="$(awk -F, 'NR == 2 { print $5 }' "$csv")"
  plot_cmd="$(IFS=,; echo "${plots[*]}")"
  plot "$dir/verify_bake.png" <<GP
set terminal $(term 1100 750)
set termoption noenhanced
set logscale xy
set grid xtics ytics mxtics mytics lc rgb "#cccccc" dt 3
set xlabel "bake time (s, wall, 2 threads)"
set ylabel "relMSE of the lookup frame against the converged reference"
set title "Bake: time against error, transport (solid) and photon (dashed) estimators ($pts splats)"
set key top right box opaque font ",9"
set arrow from graph 0, first 0.01 to graph 1, first 0.01 nohead dt 4 lc rgb "#b40000"
plot $plot_cmd
GP
fi

# ---- 2b. global illumination on concave close-ups ---------------------------
csv="$dir/gi.csv"
if [ -f "$csv" ]; then
  # columns: 1 scene, 2 estimator, 3 label, 13 total_cpu_s, 14 rel_mse, 20 ref_noise, 24 chart (on the curve),
  # 25 surface: the chart is the MLS ladder (the ISO and hybrid rows are gi.md's surfaces table)
  scenes="$(awk -F, 'NR > 1 && $25 == "mls" && !seen[$1]++ { print $1 }' "$csv")"
  n="$(echo "$scenes" | wc -l)"
  cols=$(( n < 2 ? n : 2 )); rows=$(( (n + cols - 1) / cols ))
  {
    echo "set terminal $(term $((650 * cols)) $((480 * rows)))"
    echo "set termoption noenhanced"
    echo "set multiplot layout $rows,$cols title \"Bake error against total CPU time (world + bake + one 512x512 frame) on concave close-ups and the room\""
    echo "set logscale xy"
    echo "set grid xtics ytics mxtics mytics lc rgb \"#cccccc\" dt 3"
    echo "set key bottom left box opaque font \",8\""
    echo "set xlabel \"CPU seconds, both threads\""
    echo "set ylabel \"relMSE against the reference\""
    for sc in $scenes; do
      awk -F, -v s="$sc" 'NR > 1 && $1 == s && $25 == "mls" && $2 == "transport" && $24 == 1 { print $13, $14, $3 }' "$csv" | sort -n >"$tmpd/gi_t_$sc"
      awk -F, -v s="$sc" 'NR > 1 && $1 == s && $25 == "mls" && $2 == "photons" && $24 == 1 { print $13, $14, $3 }' "$csv" | sort -n >"$tmpd/gi_p_$sc"
      noise="$(awk -F, -v s="$sc" 'NR > 1 && $1 == s && $25 == "mls" { print $20; exit }' "$csv")"
      echo "set title \"$sc\""
      echo "unset arrow"
      echo "set arrow from first 38, graph 0 to first 38, graph 1 nohead dt 3 lc rgb \"#7f7f7f\""
      echo "plot \"$tmpd/gi_t_$sc\" u 1:2 w lp lw 2 pt 7 lc rgb \"#1f6fb4\" t \"transport (default estimator)\", \\"
      echo "     \"$tmpd/gi_t_$sc\" u 1:2:3 w labels offset char 0,0.9 font \",7\" tc rgb \"#1f6fb4\" notitle, \\"
      echo "     \"$tmpd/gi_p_$sc\" u 1:2 w lp lw 2 dt 2 pt 5 lc rgb \"#d62728\" t \"photons (first estimator)\", \\"
      echo "     \"$tmpd/gi_p_$sc\" u 1:2:3 w labels offset char 0,-0.9 font \",7\" tc rgb \"#d62728\" notitle, \\"
      echo "     $noise w l dt 3 lc rgb \"#555555\" t \"the reference's own noise (floor of the measure)\", \\"
      echo "     0.003 w l dt 4 lc rgb \"#b40000\" t \"relMSE 0.003 (green: 0.002)\", \\"
      echo "     0.002 w l dt 4 lc rgb \"#2ca02c\" notitle, \\"
      echo "     NaN w l dt 3 lc rgb \"#7f7f7f\" t \"38 CPU s: a Cycles vertex bake's 0.0031 (issue 12, another scene)\""
    done
    echo "unset multiplot"
  } >"$tmpd/gi.gp"
  plot "$dir/verify_gi.png" <"$tmpd/gi.gp"
fi

# ---- 3. scaling with model size --------------------------------------------
csv="$dir/scaling.csv"
if [ -f "$csv" ] && [ "$(wc -l <"$csv")" -gt 2 ]; then
  # 1 points, 3 build_s, 4 scene_mib, 5 rss_mib, 7 direct_fps, 9 nodes, 10 leaves, 11 isects, 12 splats,
  # 13 bake_s, 14 bake_mib, 16 lookup_fps, 17 frame_size, 18 model (absent before the ISO: MLS)
  fs="$(awk -F, 'NR == 2 { print $17 }' "$csv")"
  # Per panel: the series (column, dash type, title); per model one colour.
  panel() { # panel COL:DT:TITLE ... -> a plot command over every model present
    local out=() i spec col dt t
    for i in "${!models[@]}"; do
      [ -s "$tmpd/sc_${models[$i]}" ] || continue
      for spec in "$@"; do
        col="${spec%%:*}" spec="${spec#*:}" dt="${spec%%:*}" t="${spec#*:}"
        out+=("\"$tmpd/sc_${models[$i]}\" u 1:$col w lp lw 2 dt $dt pt ${model_pt[$i]} lc rgb \"${model_colour[$i]}\" t \"${model_title[$i]}: $t\"")
      done
    done
    (IFS=,; echo "${out[*]}")
  }
  for m in "${models[@]}"; do
    awk -F, -v m="$m" 'NR > 1 && ($18 == "" ? "mls" : $18) == m' "$csv" | tr ',' ' ' >"$tmpd/sc_$m"
  done
  plot "$dir/verify_scaling.png" <<GP
set terminal $(term 1500 1050)
set multiplot layout 2,2 title "Scaling with model size per surface model (model alone, ${fs}x${fs} frames)"
set logscale x
set grid lc rgb "#cccccc"
set key top right box opaque font ",8"
set xlabel "points"
set format x "10^{%L}"
set logscale y
set ylabel "frames per second"
set title "frame rate"
plot $(panel "7:1:direct renderer (1 ray/pixel)" "16:2:bake lookup frame")
set ylabel "MiB"
set title "memory"
set key top left
plot $(panel "4:1:scene" "14:2:bake" "5:3:process RSS")
unset logscale y
set ylabel "per primary ray"
set yrange [0:45]
set key top right
set title "traversal (sg\\\\_ray\\\\_stats)"
plot $(panel "9:1:node steps" "10:2:leaves" "12:3:splats evaluated")
set logscale y
set autoscale y
set key top left
set ylabel "seconds"
set title "build and bake time"
plot $(panel "3:1:world build (sampling, radii, tree)" "13:2:bake")
unset multiplot
GP
fi

# ---- 4. the stability map ---------------------------------------------------
csv="$dir/stability.csv"
if [ -f "$csv" ]; then
  # Columns of stability.csv: 1 case, 2 model, 3 status, 7 hole_rate, 9 normal_err_deg, 11 bake_rel_mse,
  # 12 bake_energy_ratio, 14 bake_nan, 15 ref_nan, 23 ref_energy_vs_clean, 25 back_hit_rate.
  # Cells: x = metric x model, y = case; colour = badness in [0, 1] on each metric's own scale.
  nm=${#models[@]}
  awk -F, -v mlist="${models[*]}" '
    BEGIN { n = 0; nm = split(mlist, ml, " "); for (i = 1; i <= nm; i++) mi[ml[i]] = i - 1 }
    NR == 1 { next }
    !($2 in mi) { next }
    { if (!($1 in row)) { row[$1] = n; name[n++] = $1 }
      m = mi[$2]; y = row[$1]
      ok = ($3 == "ok" || $3 == "nan")
      v[0] = $7 * 100;             s[0] = 10;    f[0] = "%.1f"   # holes %
      v[1] = $9;                   s[1] = 30;    f[1] = "%.1f"   # normal error, degrees
      v[2] = ($12 - 1) * 100;      s[2] = 20;    f[2] = "%+.1f"  # energy error %
      v[3] = $11;                  s[3] = 0.1;   f[3] = "%.3f"   # relMSE
      v[4] = $14 + $15;            s[4] = 1;     f[4] = "%d"     # NaN pixels
      v[5] = ($23 == "" ? "" : ($23 - 1) * 100); s[5] = 10; f[5] = "%+.1f" # reference energy vs clean %
      v[6] = $25 * 100;            s[6] = 1;     f[6] = "%.2f"   # back hits, % of the reference hits
      for (k = 0; k < 7; k++) {
        x = nm * k + m
        if (!ok) { c = 1; lab = $3 }
        else if (v[k] == "") { c = -1; lab = "-" }
        else { a = v[k] < 0 ? -v[k] : v[k]; c = a / s[k]; if (c > 1) c = 1; lab = sprintf(f[k], v[k]) }
        cell[x, y] = c; text[x, y] = lab
      }
    }
    END {
      for (y = 0; y < n; y++) for (x = 0; x < 7 * nm; x++)
        print x, n - 1 - y, ((x, y) in cell ? cell[x, y] : -1), ((x, y) in text ? text[x, y] : "-") > "'"$tmpd"'/st"
      for (y = 0; y < n; y++) print n - 1 - y, name[y] > "'"$tmpd"'/st_names"
      print n > "'"$tmpd"'/st_n"
    }' "$csv"
  n="$(cat "$tmpd/st_n")"
  ytics="$(awk '{ printf "%s\"%s\" %d", (NR > 1 ? ", " : ""), $2, $1 }' "$tmpd/st_names")"
  metric=("holes %%" "normal err deg" "bake energy %%" "bake relMSE" "NaN px" "ref vs clean %%" "back hits %%")
  scale=(10 30 20 0.1 1 10 1)
  xt="" x2t=""
  for k in "${!metric[@]}"; do
    for m in "${!models[@]}"; do
      xt+="${xt:+, }\"${metric[$k]}\\n${model_title[$m]}\" $((nm * k + m))"
    done
    x2t+="${x2t:+, }\"scale ${scale[$k]}\" $(awk -v k="$k" -v nm="$nm" 'BEGIN { print nm * k + (nm - 1) / 2 }')"
  done
  plot "$dir/verify_stability.png" <<GP
set terminal $(term $((300 + 90 * 7 * nm)) $((140 + 34 * n)))
set title "Stability map: case x method (colour: 0 = fine, red = at or beyond the column's scale; grey: n/a)"
set xrange [-0.5:$((7 * nm)) - 0.5]
set yrange [-0.5:$n - 0.5]
set xtics ($xt) font ",8"
set x2tics ($x2t) font ",8"
set ytics ($ytics) font ",9" noenhanced
set cbrange [-1:1]
set palette defined (-1 "#dddddd", -0.001 "#dddddd", 0 "#ffffff", 0.3 "#ffe9a8", 0.7 "#f59b5b", 1 "#c8102e")
unset colorbox
set lmargin 16
set bmargin 4
plot "$tmpd/st" u 1:2:3 w image notitle, "$tmpd/st" u 1:2:4 w labels font ",9" notitle
GP
fi

# ---- 5. hybrid level of detail: speed against error (Ye 2005 fig. 11) -------
csv="$dir/hybrid.csv"
[ -f "$csv" ] || csv="$dir/../bench_hybrid.csv"
if [ -f "$csv" ] && grep -q ',hybrid-lod,' "$csv"; then
  # bench_hybrid --csv columns (the first, machine, is quoted without commas): 3 scene, 4 triangles,
  # 5 view, 6 method, 7 lod, 9 memory_mib, 11 embree_memory_mib, 13 fps, 16 embree_fps (the row's own),
  # 17 ratio (fps / that), 21 lod_hit, 23 rel_mse (vs the hybrid's full-detail frame)
  colours=("#1f6fb4" "#d62728" "#2ca02c" "#ff7f0e")
  left=() right=() i=0 emb=()
  for sv in $(awk -F, 'NR > 1 && $6 == "hybrid-lod" && !seen[$3 "/" $5]++ { print $3 "/" $5 }' "$csv"); do
    sc="${sv%/*}" vw="${sv#*/}" f="$tmpd/hl_${sc}_$vw" c="${colours[$((i % 4))]}"
    awk -F, -v s="$sc" -v v="$vw" 'NR > 1 && $3 == s && $5 == v && $6 == "hybrid-lod" {
        printf "%g %g %g %s\n", 1000 / $13, ($23 > 0 ? $23 : 1e-6), $17, ($7 == 0 ? "full" : $7 "px") }' "$csv" |
      sort -n >"$f"
    [ -s "$f" ] || continue
    tri="$(awk -F, -v s="$sc" 'NR > 1 && $3 == s { printf "%.1fM", $4 / 1e6; exit }' "$csv")"
    mem="$(awk -F, -v s="$sc" 'NR > 1 && $3 == s { printf "%.0f / %.0f MiB", $9, $11; exit }' "$csv")"
    # Embree's full-detail frame: the best (fastest) of its frames beside this scene and view's rows.
    e="$(awk -F, -v s="$sc" -v v="$vw" 'NR > 1 && $3 == s && $5 == v && (b == "" || $16 > b) { b = $16 } END { print 1000 / b }' "$csv")"
    t="$sc ($tri triangles, hybrid / Embree $mem), $vw"
    left+=("\"$f\" u 1:2 w lp lw 2 pt 7 ps 1.3 lc rgb \"$c\" t \"$t\"")
    left+=("\"$f\" u 1:2:4 w labels offset char 0,0.9 font \",8\" tc rgb \"$c\" notitle")
    emb+=("set arrow from $e, graph 0 to $e, graph 1 nohead dt 3 lw 1.5 lc rgb \"$c\"")
    right+=("\"$f\" u 3:2 w lp lw 2 pt 7 ps 1.3 lc rgb \"$c\" t \"$t\"")
    right+=("\"$f\" u 3:2:4 w labels offset char 0,0.9 font \",8\" tc rgb \"$c\" notitle")
    i=$((i + 1))
  done
  if [ ${#left[@]} -gt 0 ]; then
    {
      echo "set terminal $(term 1500 650)"
      echo "set termoption noenhanced"
      echo "set multiplot layout 1,2 title \"Hybrid point/triangle hierarchy: level-of-detail threshold as speed against error (Ye 2005 fig. 11; 512x512 primary rays, $(awk -F, 'NR == 2 { print $2 }' "$csv") threads)\""
      echo "set logscale y"
      echo "set logscale x"
      echo "set grid xtics ytics mxtics mytics lc rgb \"#cccccc\" dt 3"
      echo "set key at graph 0.99, graph 0.5 right top box opaque font \",8\""
      echo "set yrange [1e-6:0.3]"
      echo "set ylabel \"relMSE against the hybrid's full-detail frame (0 drawn at 1e-6)\""
      echo "set xlabel \"frame time, ms (best of the row's frames); dotted: Embree 3, full detail\""
      echo "set title \"frame time against error per threshold (full = 0 px)\""
      echo "set arrow from graph 0, first 0.005 to graph 1, first 0.005 nohead dt 4 lc rgb \"#b40000\""
      printf '%s\n' "${emb[@]}"
      echo "set format y \"%.0e\""
      echo "plot $(IFS=,; echo "${left[*]}"), NaN w l dt 4 lc rgb \"#b40000\" t \"relMSE 0.005 (the issue's bound for LOD 1)\""
      echo "unset arrow"
      echo "set xlabel \"speed relative to Embree 3 at full detail (fps / the row's own Embree fps; > 1: faster)\""
      echo "set title \"the same, against the Embree frame measured beside each (load-independent)\""
      echo "set arrow from graph 0, first 0.005 to graph 1, first 0.005 nohead dt 4 lc rgb \"#b40000\""
      echo "set arrow from 1, graph 0 to 1, graph 1 nohead dt 4 lc rgb \"#555555\""
      echo "plot $(IFS=,; echo "${right[*]}"), NaN w l dt 4 lc rgb \"#b40000\" t \"relMSE 0.005 (the issue's bound for LOD 1)\""
      echo "unset multiplot"
    } >"$tmpd/hl.gp"
    plot "$dir/verify_hybrid_lod.png" <"$tmpd/hl.gp"
  fi
fi
