#!/usr/bin/env bash
# The "Kernel paths" table of docs/benchmarks.md: Fandisk0.3 at every default
# on every kernel path this CPU runs (NORMALNET_ISA forces each), in one run
# on one machine, wall time with the threads given (default 2) and CPU time
# with one thread, E_a beside it; then the training engine's samples/s per
# path (crates/cnn/benches/train.rs, one thread).
#   docs/kernel_paths.sh [THREADS] [ITERATIONS_FOR_SCALAR]
# The scalar path runs only ITERATIONS_FOR_SCALAR (default 2) iterations
# (at every default it takes tens of minutes on 2 cores); the other paths are
# also timed at that count so the ratios compare like with like.
set -euo pipefail
cd "$(dirname "$0")/.."
THREADS=${1:-2}
SCALAR_IT=${2:-2}
B=target/release/normalnet
F=../shared/data/gd/Fandisk0.3
cargo build --release -q -p normalnet-cli
OUT=$(mktemp -d)
trap 'rm -rf "$OUT"' EXIT
grep -m1 'model name' /proc/cpuinfo
echo "| path | Fandisk0.3 defaults, -j $THREADS, wall s | -j 1, CPU s | E_a (°) | $SCALAR_IT iterations, -j 1, CPU s | E_a (°) |"
echo "|---|---:|---:|---:|---:|---:|"
for isa in avx512vnni avx512 avx2 scalar; do
  if ! NORMALNET_ISA=$isa $B models > /dev/null 2>&1; then
    echo "| $isa | (not on this CPU) | | | | |"
    continue
  fi
  full="–"; full_ea="–"; full_cpu="–"
  if [ "$isa" != scalar ]; then
    full_cpu=$( { NORMALNET_ISA=$isa perf stat -x, -e task-clock $B -q -j 1 denoise $F/Noisy.obj "$OUT/$isa-1.obj" \
        > /dev/null; } 2>&1 | awk -F, '/task-clock/ {printf "%.2f", $1 / 1000}')
    NORMALNET_ISA=$isa $B -q -j "$THREADS" denoise $F/Noisy.obj "$OUT/$isa.obj" --gt $F/Original.obj --json > "$OUT/$isa.json"
    full=$(python3 -c "import json; v=json.load(open('$OUT/$isa.json')); print(f\"{v['denoise_seconds']:.2f}\")")
    full_ea=$(python3 -c "import json; v=json.load(open('$OUT/$isa.json')); print(f\"{v['metrics']['e_a_deg']:.4f}\")")
  fi
  cpu=$( { NORMALNET_ISA=$isa perf stat -x, -e task-clock $B -q -j 1 denoise $F/Noisy.obj "$OUT/$isa-short.obj" \
      --iterations "$SCALAR_IT" --gt $F/Original.obj --json > "$OUT/$isa-short.json"; } 2>&1 | awk -F, '/task-clock/ {printf "%.2f", $1 / 1000}')
  short_ea=$(python3 -c "import json; v=json.load(open('$OUT/$isa-short.json')); print(f\"{v['metrics']['e_a_deg']:.4f}\")")
  echo "| $isa | $full | $full_cpu | $full_ea | $cpu | $short_ea |"
done
echo
for isa in avx512vnni avx512 avx2 scalar; do
  NORMALNET_ISA=$isa $B models > /dev/null 2>&1 || continue
  echo "training ($isa):"
  NORMALNET_ISA=$isa cargo bench -q -p normalnet-cnn --bench train -- 1 2>/dev/null | grep samples/s
done
