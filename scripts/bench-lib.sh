# bench-lib.sh — sourced by scripts/bench-{ref,bake,view}.sh: what they do
# alike before drawing their own charts.
#
# bench_run NAME ARGS...  builds bench/NAME (Release, SG_BUILD_BENCH) into
#   $build (SG_BENCH_BUILD_DIR, default build-bench), chooses the output
#   folder $outdir (docs; out with --quick; a given --out-dir wins), and
#   runs NAME --out-dir $outdir ARGS... (NAME ARGS... when ARGS has its own
#   --out-dir; --help: NAME's help, then exit).
# bench_term W H  sets $term for a W x H chart: pngcairo (smoother text and
#   dashes) when gnuplot has it, else plain png (libgd).

bench_run() {
  local name="$1"
  shift
  build="${SG_BENCH_BUILD_DIR:-build-bench}"
  cmake -S . -B "$build" -DCMAKE_BUILD_TYPE=Release -DSG_BUILD_BENCH=ON >/dev/null
  cmake --build "$build" -j "$(nproc)" --target "$name"
  outdir=docs
  local args=("$@") i
  for ((i = 0; i < ${#args[@]}; i++)); do
    case "${args[$i]}" in
      --quick) outdir=out ;;
      --help) exec "$build/bench/$name" --help ;;
    esac
  done
  local given=0
  for ((i = 0; i < ${#args[@]}; i++)); do
    if [ "${args[$i]}" = "--out-dir" ] && [ $((i + 1)) -lt ${#args[@]} ]; then
      outdir="${args[$((i + 1))]}"
      given=1
    fi
  done
  mkdir -p "$outdir"
  # A given --out-dir is passed once, as given (the program's report
  # quotes its arguments).
  if [ "$given" = 1 ]; then
    "$build/bench/$name" "$@"
  else
    "$build/bench/$name" --out-dir "$outdir" "$@"
  fi
}

bench_term() {
  if gnuplot -e 'set terminal pngcairo' >/dev/null 2>&1; then
    term="pngcairo size $1,$2 enhanced font \"sans,11\""
  else
    term="png size $1,$2"
  fi
}
