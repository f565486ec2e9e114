#!/usr/bin/env bash
# analyze_bad_options.sh POLYDEM DIR: every numeric option of `polydem analyze` refuses NaN, infinity,
# out-of-range values and trailing garbage with a message naming the option, before any work (no report
# line is printed). A usage error exits 2 (main.cpp maps CLI11 errors to 2);
# never 0, never a signal. Inputs from analyze_inputs.sh in DIR.
set -u
polydem="$(realpath "$1")"; dir="$(realpath "$2")"
packing="$dir/jam30.h5"
# "option value [extra args...]" | the regex the message must match
cases=(
  "--certify --loads 0|--loads"
  "--certify --loads -1|--loads"
  "--certify --loads 2x|--loads"
  "--pressure nan|--pressure"
  "--pressure -1|--pressure"
  "--pressure 1e6x|--pressure"
  "--contact-gap 1e-5x|--contact-gap"
  "--contact-gap -1e-5|--contact-gap"
  "--contact-gap inf|--contact-gap"
  "--gr-csv g.csv --gr-bins 0|--gr-bins"
  "--gr-csv g.csv --gr-bins 10.5|--gr-bins"
  "--gr-csv g.csv --gr-max 1|--gr-max"
  "--gr-csv g.csv --gr-max nan|--gr-max"
  "--certify --load-gap 0|--load-gap"
  "--certify --load-gap nan|--load-gap"
  "--certify --displacement-limit 1e-3x|--displacement-limit"
  "--certify --beta nan|--beta"
  "--certify --max-limit -1|--max-limit"
  "--certify --mean-limit inf|--mean-limit"
  "--certify --max-steps 0|--max-steps"
  "--certify --subpacking-rounds 0|--subpacking-rounds"
  "--certify --remove -3|--remove"
  "--certify --remove 30|--remove 30: the packing has 30 spheres"
  "--leak-test nan|--leak-test"
  "--leak-test 0|--leak-test"
  "--leak-test -5|--leak-test"
  "--leak-test 100 --leak-blocks 3|--leak-blocks"
  "--leak-test 100 --leak-tolerance 0|--leak-tolerance"
  "--leak-test 100 --leak-drift 1|--leak-drift"
  "--leak-test 100 --leak-drift nan|--leak-drift"
  "--sk-csv s.csv --sk-kmax 0|--sk-kmax"
  "--sk-csv s.csv --sk-kmax 20x|--sk-kmax"
  "--sk-csv s.csv --sk-max-vectors -1|--sk-max-vectors"
  "--velocity-rattlers=abc|--velocity-rattlers"
  "--velocity-rattlers=-1|--velocity-rattlers"
  "--loads 3|--loads needs --certify"
  "--motion-csv m.csv|--motion-csv needs --certify"
  "--leak-blocks 10|--leak-blocks needs --leak-test"
  "--remove 0|--remove needs --certify or --leak-test"
  "--gr-max 2|--gr-max needs --gr-csv"
  "--structure-only --certify|--certify needs the contact network"
  "--certify --strict|--strict needs --load-test single"
  "--broad-phase nosuch|--broad-phase: unknown broad phase 'nosuch'"
)
failures=0
work="$(mktemp -d "$dir/options.XXXXXX")"
for c in "${cases[@]}"; do
  args="${c%%|*}"; expect="${c#*|}"
  # shellcheck disable=SC2086
  out="$(cd "$work" && timeout 60 "$polydem" analyze "$packing" $args 2>&1)"; code=$?
  echo "[$code] analyze jam30.h5 $args: $(head -1 <<<"$out")"
  problem=""
  if [ "$code" -ne 2 ]; then problem="exit code $code"; fi
  if ! grep -Eq -- "$expect" <<<"$out"; then problem="$problem; message does not match '$expect'"; fi
  if grep -q "packing fraction" <<<"$out"; then problem="$problem; a report was printed before the error"; fi
  if ls -A "$work" | grep -q .; then problem="$problem; a file was written"; fi
  if [ -n "$problem" ]; then echo "FAIL: $problem"; echo "$out"; failures=$((failures + 1)); fi
done
rm -rf "$work"
echo "$failures failures"
[ "$failures" -eq 0 ]
