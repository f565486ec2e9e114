#!/usr/bin/env bash
# analyze_degenerate.sh POLYDEM DIR: every option combination of `polydem analyze` on N = 0, 1, 2 and dilute
# gases (inputs from analyze_inputs.sh in DIR). Each run must end with 0 or a clear error (2), never a signal;
# no output and no written file may contain nan; a report never calls an empty backbone "hyperstatic" or
# anything here "jammed" (every backbone is empty); no temporary file is left behind. The plain report
# (with --pressure) must succeed on every input, and no run may take a minute (the old leak test on one
# sphere never ended).
set -u
polydem="$(realpath "$1")"; dir="$(realpath "$2")"
inputs=(empty.txt one.txt two.txt one_walls.txt two_v.txt gas.txt gas.h5 gas_walls.txt)
combos=(
  "--pressure 1e6"
  "--pressure 1e6 --certify --leak-test 50"
  "--pressure 1e6 --certify --no-ideal --load-test single --subpacking-rounds 3 --motion-csv m.csv"
  "--pressure 1e6 --certify --remove 0 --leak-test 50 --leak-blocks 4"
  "--pressure 1e6 --certify --strict --load-test single"
  "--contact-gap 1e-3 --z-csv z.csv --gr-csv g.csv --gr-max 2"
  "--pressure 2 --order --channels-csv c.csv --sk-csv s.csv --sk-kmax 5"
  "--structure-only --order --channels-csv c.csv --sk-csv s.csv --sk-kmax 5"
  "--structure-only --velocity-rattlers"
  "--pressure 1e6 --velocity-rattlers=1e-3"
)
failures=0
for input in "${inputs[@]}"; do
  for combo in "${combos[@]}"; do
    work="$(mktemp -d "$dir/run.XXXXXX")"
    # shellcheck disable=SC2086
    out="$(cd "$work" && timeout 60 "$polydem" analyze "$dir/$input" $combo 2>&1)"; code=$?
    problem=""
    if [ "$code" -eq 124 ]; then problem="still running after 60 s"; fi
    if [ "$code" -ne 0 ] && [ "$code" -ne 2 ]; then problem="$problem; exit code $code"; fi
    if grep -Eiwq -- '-?nan' <<<"$out"; then problem="$problem; nan in the output"; fi
    if grep -Eq 'hyperstatic' <<<"$out"; then problem="$problem; hyperstatic"; fi
    if grep -Eq '(^|[^n])jammed' <<<"$out"; then problem="$problem; a jammed verdict"; fi
    for f in "$work"/*.csv; do
      [ -e "$f" ] || continue
      if grep -Eiwq -- '-?nan' "$f"; then problem="$problem; nan in $(basename "$f")"; fi
    done
    if ls -A "$work" | grep -q '\.tmp-'; then problem="$problem; temporary file left"; fi
    if [ "$combo" = "--pressure 1e6" ] && [ "$code" -ne 0 ]; then problem="$problem; the plain report failed"; fi
    if [ "$code" -eq 2 ] && ! grep -q '^polydem: ' <<<"$out"; then problem="$problem; exit 2 without a message"; fi
    echo "[$code] analyze $input $combo: $(grep -E '^polydem: |smallest gap|isostaticity|LP test|loads\)|leak test  ' <<<"$out" | tr '\n' '|' | cut -c1-300)"
    if [ -n "$problem" ]; then
      echo "FAIL: $problem"; echo "$out"; failures=$((failures + 1))
    fi
    rm -rf "$work"
  done
done
echo "$failures failures"
[ "$failures" -eq 0 ]
