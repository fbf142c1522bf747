#!/usr/bin/env bash
# The "Kernel paths" tables of docs/benchmarks.md: every kernel path this CPU
# runs (NORMALNET_ISA forces each), in one run on one machine:
#  - Fandisk0.3 at every default: wall time with THREADS threads, CPU time
#    with one thread, E_a; ITERATIONS_FOR_SCALAR iterations on every path
#    (the scalar path at every default takes tens of minutes on 2 cores);
#  - the 100k-face torus of `crates/denoise/examples/large.rs` (one thread:
#    CPU time and peak RSS; the scalar path only 1 iteration);
#  - the training engine's samples/s (crates/cnn/benches/train.rs, 1 thread);
#  - with MILLION="avx512vnni avx2" (paths), the 1M-face torus at every
#    default with THREADS threads: wall time and peak RSS.
#   docs/kernel_paths.sh [THREADS] [ITERATIONS_FOR_SCALAR]
# Environment: NORMALNET, LARGE, TRAIN_BENCH name built binaries (default:
# built here with cargo); SHARED the data folder (default ../shared);
# PARALLEL=1 runs the paths at once, each pinned to its own THREADS physical
# cores (docs/timed.py), for machines with many cores; JOB_TIMEOUT (s) ends
# any one measurement that runs longer (its row then says so).
# CPU time and peak RSS come from docs/timed.py (the child's rusage), so
# neither perf nor GNU time is needed.
set -euo pipefail
cd "$(dirname "$0")/.."
THREADS=${1:-2}
SCALAR_IT=${2:-2}
SHARED=${SHARED:-../shared}
F=$SHARED/data/gd/Fandisk0.3
PATHS="avx512vnni avx512 avxvnni avx2 scalar"
if [ -z "${NORMALNET:-}" ]; then
  cargo build --release -q -p normalnet-cli
  NORMALNET=target/release/normalnet
fi
if [ -z "${LARGE:-}" ]; then
  cargo build --release -q -p normalnet-denoise --example large
  LARGE=target/release/examples/large
fi
if [ -z "${TRAIN_BENCH:-}" ]; then
  TRAIN_BENCH=$(cargo bench -p normalnet-cnn --bench train --no-run 2>&1 |
    sed -n 's/.*Executable.*(\(.*\)).*/\1/p' | head -1)
fi
W=$(mktemp -d)
trap 'rm -rf "$W"' EXIT

# measure REPORT CPUS COMMAND...: runs COMMAND pinned to CPUS; REPORT gets
# `wall_s cpu_s peak_rss_mb rc`, REPORT.out the command's stdout.
measure() {
  local report=$1 cpus=$2
  shift 2
  python3 docs/timed.py run --cpus "$cpus" --timeout "${JOB_TIMEOUT:-0}" -- "$@" \
    > "$report.out" 2> "$report.err" || true
  tail -1 "$report.err" > "$report"
}
field() { awk -v k="$2" '{ print $k }' "$1"; }
ok() { [ "$(field "$1" 4)" = 0 ]; }
ea() { python3 -c "import json,sys; print(f\"{json.load(open(sys.argv[1]))['metrics']['e_a_deg']:.4f}\")" "$1"; }

# lane ISA CPUS: every measurement of one path, its one-thread runs on the
# first of CPUS.
lane() (
  isa=$1 cpus=$2 one=${2%%,*} r=$W/$1
  export NORMALNET_ISA=$isa
  full=– full_cpu=– full_ea=– big=– big_rss=–
  if [ "$isa" != scalar ]; then
    measure "$r.full1" "$one" "$NORMALNET" -q -j 1 denoise "$F/Noisy.obj" "$W/$isa-1.obj"
    ok "$r.full1" && full_cpu=$(field "$r.full1" 2)
    measure "$r.full" "$cpus" "$NORMALNET" -q -j "$THREADS" denoise "$F/Noisy.obj" "$W/$isa.obj" \
      --gt "$F/Original.obj" --json
    if ok "$r.full"; then
      full=$(python3 -c "import json,sys; print(f\"{json.load(open(sys.argv[1]))['denoise_seconds']:.2f}\")" "$r.full.out")
      full_ea=$(ea "$r.full.out")
    fi
  fi
  measure "$r.short" "$one" "$NORMALNET" -q -j 1 denoise "$F/Noisy.obj" "$W/$isa-short.obj" \
    --iterations "$SCALAR_IT" --gt "$F/Original.obj" --json
  short=– short_ea=–
  ok "$r.short" && short=$(field "$r.short" 2) && short_ea=$(ea "$r.short.out")
  echo "| $isa | $full | $full_cpu | $full_ea | $short | $short_ea |" | tee "$r.row" >&2
  large_args=() what="every default"
  [ "$isa" = scalar ] && large_args=(iterations=1) && what="1 iteration"
  measure "$r.big" "$one" env RAYON_NUM_THREADS=1 "$LARGE" normalnet 158 "${large_args[@]}"
  ok "$r.big" && big=$(field "$r.big" 2) && big_rss=$(field "$r.big" 3)
  ok "$r.big" || big="(rc $(field "$r.big" 4) after $(field "$r.big" 1) s)"
  echo "| $isa | $what | $big | $big_rss |" | tee "$r.bigrow" >&2
  measure "$r.train" "$one" "$TRAIN_BENCH" 1
  echo "| $isa | $(grep -o '[0-9.]* ms/step, [0-9]* samples/s' "$r.train.out" || echo –) |" | tee "$r.trainrow" >&2
)

# million ISA CPUS: the 1M-face torus at every default.
million() {
  local r=$W/$1.million
  measure "$r" "$2" env NORMALNET_ISA="$1" RAYON_NUM_THREADS="$THREADS" "$LARGE" normalnet 500
  local wall
  wall=$(field "$r" 1)
  ok "$r" || wall="(rc $(field "$r" 4) after $wall s)"
  echo "| $1 | $wall | $(field "$r" 3) |" | tee "$r.row" >&2
}

grep -m1 'model name' /proc/cpuinfo
IFS=, read -r -a CORES <<< "$(python3 docs/timed.py cores)"
echo "physical cores: ${#CORES[@]}; threads per path: $THREADS; parallel: ${PARALLEL:-0}"
RUNS=()
for isa in $PATHS; do
  NORMALNET_ISA=$isa "$NORMALNET" models > /dev/null 2>&1 && RUNS+=("lane $isa")
done
for isa in ${MILLION:-}; do
  NORMALNET_ISA=$isa "$NORMALNET" models > /dev/null 2>&1 && RUNS+=("million $isa")
done
next=0
for run in "${RUNS[@]}"; do
  cpus=""
  if [ "${PARALLEL:-0}" = 1 ]; then
    for ((k = 0; k < THREADS; k++)); do
      cpus+="${cpus:+,}${CORES[$(((next + k) % ${#CORES[@]}))]}"
    done
    next=$((next + THREADS))
    $run "$cpus" &
  else
    cpus=$(IFS=,; echo "${CORES[*]:0:$THREADS}")
    $run "$cpus"
  fi
done
[ "$next" -gt "${#CORES[@]}" ] && echo "warning: $next cores asked, ${#CORES[@]} there: paths shared cores"
wait

echo
echo "Fandisk0.3:"
echo "| path | defaults, -j $THREADS, wall s | defaults, -j 1, CPU s | E_a (°) | $SCALAR_IT iterations, -j 1, CPU s | E_a (°) |"
echo "|---|---:|---:|---:|---:|---:|"
for isa in $PATHS; do cat "$W/$isa.row" 2> /dev/null || echo "| $isa | (not on this CPU) | | | | |"; done
echo
echo "100k-face torus (\`large normalnet 158\`, 99,856 faces), one thread:"
echo "| path | run | CPU s | peak RSS MB |"
echo "|---|---|---:|---:|"
for isa in $PATHS; do cat "$W/$isa.bigrow" 2> /dev/null || true; done
echo
echo "Training engine (\`train\` bench, lite, batch 80, one thread):"
echo "| path | speed |"
echo "|---|---|"
for isa in $PATHS; do cat "$W/$isa.trainrow" 2> /dev/null || true; done
if [ -n "${MILLION:-}" ]; then
  echo
  echo "1M-face torus (\`large normalnet 500\`, 1,000,000 faces), every default, -j $THREADS:"
  echo "| path | wall s | peak RSS MB |"
  echo "|---|---:|---:|"
  for isa in $MILLION; do cat "$W/$isa.million.row" 2> /dev/null || true; done
fi
