#!/usr/bin/env bash
# jam_resume_wide.sh POLYDEM WORKDIR: a wide size distribution (uniform radius, size ratio 6: three size
# classes with their own skin floors, issue 24) jammed uninterrupted and the same run stopped at block 25
# (checkpoint) and resumed: the final particle files (text, %.17g) must be byte-identical, so the class
# floors and counters travel through the checkpoint file.
set -u
polydem="$1"; work="$2/jam_resume_wide"; rm -rf "$work"; mkdir -p "$work"; cd "$work" || exit 1
run=(jam -n 300 --dist uniform-radius --omega 6 --schedule 1e-2:1e2,1e-3 --target-pressure 1e5 --seed 4
     --progress 0)
fail() { echo "FAIL: $*"; exit 1; }
"$polydem" "${run[@]}" -o a.txt > a.log 2>&1 || { cat a.log; fail "uninterrupted run exit $?"; }
"$polydem" "${run[@]}" -o b.txt --checkpoint b.ckpt.h5 --stop-after-blocks 25 > b1.log 2>&1
code=$?
[ "$code" = 130 ] || { tail -n 5 b1.log; fail "stopped run exit $code, expected 130"; }
"$polydem" jam --resume b.ckpt.h5 > b2.log 2>&1 || { cat b2.log; fail "resume exit $?"; }
cmp a.txt b.txt || fail "final text files differ"
echo "PASS: resumed wide-distribution run byte-identical ($(wc -l < a.txt) lines)"
