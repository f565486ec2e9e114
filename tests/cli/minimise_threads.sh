#!/usr/bin/env bash
# minimise_threads.sh POLYDEM WORKDIR: the threaded force loop gives the same minimised packing, byte for
# byte, as the serial one (skipped in a build without OpenMP, where --threads 2 is refused with exit 2).
set -u
polydem="$1"; cd "$2" || exit 1
"$polydem" minimise -n 300 --phi0 0.7 --seed 5 --threads 1 --progress 0 -o minimise_t1.h5 >/dev/null || exit 1
"$polydem" minimise -n 300 --phi0 0.7 --seed 5 --threads 2 --progress 0 -o minimise_t2.h5 >/dev/null; code=$?
if [ "$code" = 2 ]; then echo "SKIP: serial build"; exit 0; fi
[ "$code" = 0 ] || exit 1
cmp minimise_t1.h5 minimise_t2.h5 && echo "PASS: --threads 2 output identical to --threads 1"
