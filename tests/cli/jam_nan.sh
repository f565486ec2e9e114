#!/usr/bin/env bash
# jam_nan.sh POLYDEM WORKDIR: NaN (and inf) given to any numeric option of jam is refused with a message
# naming the option, before anything runs.
set -u
polydem="$1"; cd "$2" || exit 1
status=0
for option in --count --phi0 --target-pressure --target-phi --max-collisions --block --neighbourhood-scale \
              --skin-cap --contact-gap --run-collisions --progress --checkpoint-interval --reopen; do
  for value in nan inf; do
    out="$("$polydem" jam "$option" "$value" 2>&1)"; code=$?
    if [ "$code" = 0 ] || [ "$code" -ge 128 ] || ! grep -q -- "$option" <<<"$out" || grep -q "coll/particle" <<<"$out"; then
      echo "FAIL: jam $option $value -> exit $code: $out"; status=1
    fi
  done
done
[ "$status" = 0 ] && echo "PASS: NaN and inf refused for every numeric option"
exit "$status"
