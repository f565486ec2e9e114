# polydem common: CLI tests (issue 15) for generate, pairs, bench, predict, example and the particle
# files every command reads and writes. See cli_helpers.cmake.
#
# Fixture particle files with N = 0, 1, 2 (written at configure time into the work directory).
file(WRITE ${POLYDEM_CLI_WORK}/common_n0.txt "0 10 10 10\n")
file(WRITE ${POLYDEM_CLI_WORK}/common_n1.txt "1 10 10 10\n5 5 5 1\n")
file(WRITE ${POLYDEM_CLI_WORK}/common_n2.txt "# boundaries: wall wall wall\n2 10 10 10\n3 5 5 1\n6 5 5 1.5\n")
file(WRITE ${POLYDEM_CLI_WORK}/common_n2_equal.txt "2 10 10 10\n3 5 5 1.5\n7 5 5 1.5\n")
file(MAKE_DIRECTORY ${POLYDEM_CLI_WORK}/common_existing_dir)
file(WRITE ${POLYDEM_CLI_WORK}/common_a_file "not a directory\n")
set(_bench --repeat 1 --out common_bench_report)

# common_reject(NAME n PASS regex COMMAND args...): refused with exit code 2, the message matching PASS;
# the value may be quoted in it (so "nan" may appear), see common_reject.sh.
function(common_reject)
  cmake_parse_arguments(T "" "NAME;PASS" "COMMAND" ${ARGN})
  add_test(NAME cli_${T_NAME}
           COMMAND bash ${CMAKE_CURRENT_SOURCE_DIR}/common_reject.sh "${T_PASS}" $<TARGET_FILE:polydem> ${T_COMMAND}
           WORKING_DIRECTORY ${POLYDEM_CLI_WORK})
  set_tests_properties(cli_${T_NAME} PROPERTIES TIMEOUT 60 LABELS "cli")
endfunction()

# --- N = 0, 1, 2: no crash; a clear error where the command cannot apply ----------------------------------
foreach(suite backends levels)
  polydem_cli_test(NAME common_bench_${suite}_n0 COMMAND bench ${suite} -i common_n0.txt ${_bench}
                   EXIT 2 PASS "common_n0.txt: 0 particles: a broad-phase benchmark needs at least 2")
  polydem_cli_test(NAME common_bench_${suite}_n1 COMMAND bench ${suite} -i common_n1.txt ${_bench}
                   EXIT 2 PASS "1 particle: a broad-phase benchmark needs at least 2")
  polydem_cli_test(NAME common_bench_${suite}_n2 COMMAND bench ${suite} -i common_n2.txt ${_bench} EXIT 0
                   PASS "report written to common_bench_report/README.md")
endforeach()
foreach(n 0 1 2)
  polydem_cli_test(NAME common_pairs_n${n} COMMAND pairs common_n${n}.txt --repeat 1 --broadphase auto EXIT 0
                   PASS "candidate pairs: 0")
  polydem_cli_test(NAME common_pairs_linked_cell_n${n} COMMAND pairs common_n${n}.txt --repeat 1
                   --broadphase linked-cell EXIT 0 PASS "candidate pairs: 0")
endforeach()
# Every backend on N = 0, 1, 2, and the hand-set hgrid levels (the cost model's sizes collapse for equal radii).
foreach(backend brute hgrid-td hgrid-bu delaunay sap cgal-box)
  foreach(n 0 1 2)
    polydem_cli_test(NAME common_pairs_${backend}_n${n} COMMAND pairs common_n${n}.txt --repeat 1 --broadphase ${backend}
                     EXIT 0 PASS "candidate pairs: 0")
  endforeach()
endforeach()
polydem_cli_test(NAME common_pairs_levels_n1 COMMAND pairs common_n1.txt --repeat 1 --broadphase hgrid-td --levels 2
                 EXIT 0 PASS "candidate pairs: 0")
polydem_cli_test(NAME common_pairs_levels_n2 COMMAND pairs common_n2.txt --repeat 1 --broadphase hgrid-td --levels 2
                 EXIT 0 PASS "candidate pairs: 0")
polydem_cli_test(NAME common_pairs_levels_n0 COMMAND pairs common_n0.txt --repeat 1 --broadphase hgrid-td --levels 2
                 EXIT 2 PASS "cost model needs at least one radius")
polydem_cli_test(NAME common_pairs_levels_n2_equal_radii COMMAND pairs common_n2_equal.txt --repeat 1
                 --broadphase hgrid-bu --levels 3 EXIT 0 PASS "candidate pairs: 0")
polydem_cli_test(NAME common_predict_n0 COMMAND predict -i common_n0.txt EXIT 2
                 PASS "common_n0.txt: holds no particles")
polydem_cli_test(NAME common_predict_n1 COMMAND predict -i common_n1.txt EXIT 0 PASS "radii of common_n1.txt \\(1 particles\\)")
polydem_cli_test(NAME common_predict_n2 COMMAND predict -i common_n2.txt EXIT 0 PASS "predicted jamming density")
polydem_cli_test(NAME common_generate_n0 COMMAND generate -n 0 -o common_gen0.txt EXIT 2 PASS "--count")
polydem_cli_test(NAME common_generate_n1 COMMAND generate -n 1 -o common_gen1.h5 EXIT 0 PASS "generated 1 particles")
polydem_cli_test(NAME common_generate_n2 COMMAND generate -n 2 --dist bi --omega 2 --fraction-kind number
                 -o common_gen2.txt EXIT 0
                 PASS "generated 2 particles")
polydem_cli_test(NAME common_example_n1 COMMAND example -n 1 --repeat 1 EXIT 0
                 PASS "all backends report the same 0 pairs")
polydem_cli_test(NAME common_example_n2 COMMAND example -n 2 --phi 0.05 --repeat 1 EXIT 0
                 PASS "all backends report the same 0 pairs")
# Two spheres cannot both fit a box at 0.3 (walls, the box is barely wider than one): a clear refusal.
polydem_cli_test(NAME common_example_n2_dense COMMAND example -n 2 --repeat 1 EXIT 2
                 PASS "random sequential addition stalled.*placing 1 of 2 spheres")
polydem_cli_test(NAME common_example_n0 COMMAND example -n 0 EXIT 2 PASS "--count")

# --- every numeric option validated, the option named ------------------------------------------------------
set(_out -o common_never.txt)
polydem_cli_test(NAME common_generate_count_negative COMMAND generate -n -5 ${_out} EXIT 2 PASS "--count")
polydem_cli_test(NAME common_generate_count_garbage COMMAND generate -n 20x ${_out} EXIT 2 PASS "--count")
common_reject(NAME common_generate_phi_nan PASS "--phi.*not a finite" COMMAND generate --phi nan ${_out})
polydem_cli_test(NAME common_generate_phi_one COMMAND generate --phi 1 ${_out} EXIT 2 PASS "--phi.*outside \\(0, 1\\)")
polydem_cli_test(NAME common_generate_omega_garbage COMMAND generate --dist uv --omega 20x ${_out} EXIT 2
                 PASS "--omega.*'20x' is not a finite number")
common_reject(NAME common_generate_omega_nan PASS "--omega" COMMAND generate --dist uv --omega nan ${_out})
polydem_cli_test(NAME common_generate_rmin_negative COMMAND generate --rmin -1 ${_out} EXIT 2 PASS "--rmin")
polydem_cli_test(NAME common_generate_fraction_above_one COMMAND generate --dist bi --omega 2 --large-fraction 1.5
                 ${_out} EXIT 2 PASS "--large-fraction")
polydem_cli_test(NAME common_generate_sigma_zero COMMAND generate --dist ln --sigma 0 ${_out} EXIT 2 PASS "--sigma")
polydem_cli_test(NAME common_generate_alpha_inf COMMAND generate --dist power-law --omega 3 --alpha inf ${_out}
                 EXIT 2 PASS "--alpha")
polydem_cli_test(NAME common_generate_aspect_zero COMMAND generate --aspect 1,0,1 ${_out} EXIT 2 PASS "--aspect")
polydem_cli_test(NAME common_generate_dist_unknown COMMAND generate --dist gaussian ${_out} EXIT 2 PASS "--dist")
polydem_cli_test(NAME common_generate_boundary_unknown COMMAND generate --boundary sticky ${_out} EXIT 2
                 PASS "--boundary.*expected periodic or wall")
polydem_cli_test(NAME common_generate_seed_negative COMMAND generate --seed -1 ${_out} EXIT 2 PASS "--seed")
common_reject(NAME common_pairs_skin_nan PASS "--skin" COMMAND pairs common_n2.txt --skin nan)
polydem_cli_test(NAME common_pairs_skin_negative COMMAND pairs common_n2.txt --skin -1 EXIT 2 PASS "--skin")
polydem_cli_test(NAME common_pairs_repeat_zero COMMAND pairs common_n2.txt --repeat 0 EXIT 2 PASS "--repeat")
polydem_cli_test(NAME common_pairs_levels_negative COMMAND pairs common_n2.txt --broadphase hgrid-td --levels -2
                 EXIT 2 PASS "--levels")
common_reject(NAME common_pairs_cell_sizes_nan PASS "--cell-sizes" COMMAND pairs common_n2.txt --broadphase hgrid-td
                 --cell-sizes 1,nan)
common_reject(NAME common_predict_phi_nan PASS "--phi" COMMAND predict --phi 0.3,nan)
polydem_cli_test(NAME common_predict_phi_garbage COMMAND predict --phi 0.3x EXIT 2 PASS "--phi")
common_reject(NAME common_predict_omega_nan PASS "--omega" COMMAND predict --dist uv --omega nan)
polydem_cli_test(NAME common_example_omega_below_one COMMAND example --omega 0.5 EXIT 2 PASS "--omega")
polydem_cli_test(NAME common_example_repeat_negative COMMAND example --repeat -1 EXIT 2 PASS "--repeat")
polydem_cli_test(NAME common_bench_repeat_negative COMMAND bench quick --repeat -1 EXIT 2 PASS "--repeat")
polydem_cli_test(NAME common_bench_phi_one COMMAND bench quick --phi 1 EXIT 2 PASS "--phi")
polydem_cli_test(NAME common_bench_count_one COMMAND bench backends -n 1 EXIT 2 PASS "--count.*needs at least 2")
polydem_cli_test(NAME common_bench_count_negative COMMAND bench quick -n -3 EXIT 2 PASS "--count")
polydem_cli_test(NAME common_bench_counts_garbage COMMAND bench trel --counts 1000,20x EXIT 2 PASS "--counts")
common_reject(NAME common_bench_equilibrate_nan PASS "--equilibrate" COMMAND bench trel --equilibrate nan)
polydem_cli_test(NAME common_bench_max_levels_zero COMMAND bench levels --max-levels 0 EXIT 2 PASS "--max-levels")

# --- outputs checked before any computation, never an input -------------------------------------------------
polydem_cli_test(NAME common_generate_output_no_directory COMMAND generate -o common_no_such_dir/x.txt EXIT 2
                 PASS "--output 'common_no_such_dir/x.txt'" FAIL "generated")
polydem_cli_test(NAME common_generate_output_is_directory COMMAND generate -o common_existing_dir EXIT 2
                 PASS "--output" FAIL "generated")
polydem_cli_test(NAME common_generate_sidecar_no_directory COMMAND generate -o common_no_such_dir/x.h5 EXIT 2
                 PASS "--output" FAIL "generated")
polydem_cli_test(NAME common_bench_out_is_file COMMAND bench backends -i common_n2.txt --repeat 1 --out common_a_file
                 EXIT 2 PASS "--out 'common_a_file': exists and is not a directory")
polydem_cli_test(NAME common_bench_out_aliases_input COMMAND bench backends -i common_existing_dir/backends.csv
                 --repeat 1 --out common_existing_dir EXIT 2 PASS "--out")
polydem_cli_test(NAME common_bench_input_only_for_file_suites COMMAND bench quick -i common_n2.txt --out
                 common_bench_report EXIT 2 PASS "--input works with the levels and backends suites")

# --- settings never silently dropped -------------------------------------------------------------------------
polydem_cli_test(NAME common_predict_input_and_dist COMMAND predict -i common_n2.txt --dist bi EXIT 2
                 PASS "--dist conflicts with --input common_n2.txt")
polydem_cli_test(NAME common_predict_input_and_omega COMMAND predict -i common_n2.txt --omega 3 EXIT 2
                 PASS "--omega conflicts with --input")
polydem_cli_test(NAME common_pairs_boundary_conflict COMMAND pairs common_n2.txt --boundary periodic EXIT 2
                 PASS "--boundary periodic conflicts with the boundaries stored in common_n2.txt")
polydem_cli_test(NAME common_pairs_boundary_default COMMAND pairs common_n1.txt --boundary walls --repeat 1 EXIT 0
                 PASS "candidate pairs: 0")

# --- a sampled distribution that cannot represent the request ------------------------------------------------
polydem_cli_test(NAME common_generate_bi_too_few COMMAND generate --dist bi --omega 1000 -n 100 -o common_bi.txt
                 EXIT 2 PASS "100 particles cannot represent it.*smallest count that works is N = 500000001"
                 FAIL "generated")
polydem_cli_test(NAME common_generate_bi_enough COMMAND generate --dist bi --omega 10 -n 501 --phi 0.05
                 -o common_bi.txt EXIT 0 PASS "generated 501 particles")

# --- particle files: metadata in text files, deterministic snapshots ----------------------------------------
add_test(NAME cli_common_particle_files
         COMMAND bash ${CMAKE_CURRENT_SOURCE_DIR}/common_particle_files.sh $<TARGET_FILE:polydem>
         WORKING_DIRECTORY ${POLYDEM_CLI_WORK})
set_tests_properties(cli_common_particle_files PROPERTIES TIMEOUT 120 LABELS "cli")
# Restart from a snapshot of a frictional relax reads its angular velocities back (relax.cmake writes relax_small.toml).
add_test(NAME cli_io_snapshot_restart
         COMMAND bash ${CMAKE_CURRENT_SOURCE_DIR}/io_snapshot_restart.sh $<TARGET_FILE:polydem>
         ${POLYDEM_CLI_WORK}/io_snapshot_restart)
set_tests_properties(cli_io_snapshot_restart PROPERTIES TIMEOUT 300 LABELS "cli;relax")
