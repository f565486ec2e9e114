#!/usr/bin/env bash
# minimise_nan.sh POLYDEM WORKDIR: NaN and inf given to any numeric option of minimise are refused (exit 2)
# with a message naming the option, before anything runs.
set -u
polydem="$1"; cd "$2" || exit 1
status=0
for option in --count --phi0 --stiffness --force-tolerance --max-iterations --dt --dt-max-factor --skin --outer-skin \
              --target-pressure --pressure-tolerance --initial-step --max-step --progress; do
  for value in nan inf; do
    out="$("$polydem" minimise -n 20 "$option" "$value" 2>&1)"; code=$?
    if [ "$code" != 2 ] || ! grep -q -- "$option" <<<"$out" || grep -q "FIRE steps" <<<"$out"; then
      echo "FAIL: minimise $option $value -> exit $code: $out"; status=1
    fi
  done
done
[ "$status" = 0 ] && echo "PASS: NaN and inf refused for every numeric option"
exit "$status"
