#!/usr/bin/env bash
# minimise_scene.sh POLYDEM WORKDIR EXAMPLE: `polydem minimise SCENE` (issue 19). (1) A scene gives the run the
# same options give; (2) a command-line option overrides a scene key; (3) relative paths in a scene are taken
# relative to the scene's directory; (4) examples/minimise_uv10.toml names every long option of the command
# (set or commented), so the example cannot fall behind the options.
set -eu
polydem="$1"; mkdir -p "$2/minimise_scene/sub"; cd "$2/minimise_scene"; example="$3"
# (the times and the broad-phase line differ run to run: auto calibrates its cost ratio K by timing)
run() { "$polydem" minimise "$@" --progress 0 | grep -Ev '^(time|broad phase) ' | sed -E 's/  [0-9.]+ s$//'; }

cat > scene.toml <<'TOML'
[minimise]
dist = "uniform-volume"
omega = 4.0
count = 150
phi0 = 0.7
seed = 3
target_pressure = 1e-3
TOML
a="$(run scene.toml)"; b="$(run --dist uniform-volume --omega 4 -n 150 --phi0 0.7 --seed 3 --target-pressure 1e-3)"
diff <(printf '%s\n' "$a") <(printf '%s\n' "$b") || { echo "FAIL: the scene and the same options differ"; exit 1; }
grep -q "^phi_J" <<<"$a" || { echo "FAIL: no phi_J"; exit 1; }

a="$(run scene.toml --target-pressure 1e-2 --seed 4)"
b="$(run --dist uniform-volume --omega 4 -n 150 --phi0 0.7 --seed 4 --target-pressure 1e-2)"
diff <(printf '%s\n' "$a") <(printf '%s\n' "$b") || { echo "FAIL: command-line options do not override the scene"; exit 1; }

printf '2 10 10 10\n5 5 5 1\n6.5 5 5 1\n' > sub/pair.txt
printf '[minimise]\ninput = "pair.txt"\noutput = "pair_out.txt"\n' > sub/scene.toml
run sub/scene.toml | grep -q "start                   file sub/pair.txt" || { echo "FAIL: input not relative to the scene"; exit 1; }
[ -s sub/pair_out.txt ] || { echo "FAIL: output not written beside the scene"; exit 1; }

missing=""
for opt in $("$polydem" minimise --help | grep -oE -- '--[a-z0-9-]+' | sort -u); do
  key="${opt#--}"; key="${key//-/_}"
  [ "$key" = help ] && continue
  grep -Eq "^#? *$key = " "$example" || missing="$missing $key"
done
[ -z "$missing" ] || { echo "FAIL: $example does not list:$missing"; exit 1; }
echo "PASS: scene = options, options override, paths relative to the scene, the example lists every key"
