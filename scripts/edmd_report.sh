#!/usr/bin/env bash
# Event-driven hard spheres: collision rates and jamming runs of issue 6, written to docs/benchmarks/edmd_report.md
# with the commands that made them. Not part of CI: the full set takes about an hour on one core.
#
#   scripts/edmd_report.sh [BUILD_DIR]        (default build/)
#   QUICK=1 scripts/edmd_report.sh            (N = 1000 jamming only, a few minutes)
set -euo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)
build=${1:-$here/build}
polydem=$build/apps/polydem
out=$here/docs/benchmarks/edmd_report.md
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

run() {  # run CMD...: echo the command into the report, then its output
  echo '```' >>"$out"
  echo "\$ $*" >>"$out"
  (cd "$work" && "$@") 2>&1 | grep -v '^phi .*wall' | tee -a "$out" >/dev/null || true
  echo '```' >>"$out"
}

{
  echo "# Event-driven hard spheres: measured results"
  echo
  echo "Written by \`scripts/edmd_report.sh\` on $(date -u +%Y-%m-%d), $(lscpu | sed -n 's/^Model name: *//p' | head -1)."
  echo "Single core (\`nice\`); rates are wall-clock and drop when the machine is shared."
  echo
} >"$out"

echo "## Collisions per second at packing fraction 0.5 (fixed density, after compression)" >>"$out"
run "$polydem" jam -n 10000 --schedule 1e-2 --target-phi 0.5 --run-collisions 100 --progress 1000
if [[ -z "${QUICK:-}" ]]; then
  run "$polydem" jam -n 10000 --dist uniform-volume --omega 10 --schedule 1e-2 --target-phi 0.5 --run-collisions 50 \
    --progress 1000
  # omega = 50 needs N = 20000 so that the largest sphere fits four times into the box edge.
  run "$polydem" jam -n 20000 --dist uniform-volume --omega 50 --schedule 1e-2 --target-phi 0.5 --run-collisions 20 \
    --progress 1000
fi

echo "## Jamming to p = 1e12" >>"$out"
run "$polydem" jam -n 1000 --schedule 1e-2:1e2,1e-3:1e4,2e-4 --target-pressure 1e12 --progress 1000 -o mono1k.h5
run "$polydem" analyze mono1k.h5 --certify
if [[ -z "${QUICK:-}" ]]; then
  run "$polydem" jam -n 10000 --schedule 1e-2:1e2,1e-3:1e4,2e-4 --target-pressure 1e12 --progress 1000 -o mono10k.h5
  run "$polydem" jam -n 10000 --dist uniform-volume --omega 10 --schedule 1e-2:1e2,1e-3:1e4,2e-4 \
    --target-pressure 1e12 --progress 1000 -o uv10.h5
  # Load tests at N = 10,000 use the interior point (1-2 minutes per LP with OpenBLAS on one thread).
  # Sequential loading (seed Algorithm 14, the default), then the single-LP ideal-limit test with rounds.
  OPENBLAS_NUM_THREADS=1 run "$polydem" analyze mono10k.h5 --certify --lp-solver interior
  OPENBLAS_NUM_THREADS=1 run "$polydem" analyze mono10k.h5 --certify --lp-solver interior --remove 0
  # The holed packing without the stopping thresholds: it keeps moving at every step (8 LPs per load).
  OPENBLAS_NUM_THREADS=1 run "$polydem" analyze mono10k.h5 --certify --lp-solver interior --remove 0 --no-ideal \
    --loads 1 --max-limit 10 --mean-limit 10 --max-steps 8
  OPENBLAS_NUM_THREADS=1 run "$polydem" analyze mono10k.h5 --certify --lp-solver interior --no-ideal \
    --load-test single --strict
  OPENBLAS_NUM_THREADS=1 run "$polydem" analyze uv10.h5 --certify --lp-solver interior --no-ideal --subpacking-rounds 12
  OPENBLAS_NUM_THREADS=1 run "$polydem" analyze uv10.h5 --certify --lp-solver interior
  OPENBLAS_NUM_THREADS=1 run "$polydem" analyze mono10k.h5 --certify --lp-solver interior --load-test single \
    --subpacking-rounds 4
fi
echo "wrote $out"
