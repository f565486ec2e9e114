# polydem minimise: CLI tests (issue 19). See cli_helpers.cmake.
# Exit codes 0/2/4, N = 0/1/2, options validated and named, output paths checked before the run, the
# hand-off from `jam` and to `analyze` (minimise_analyze.sh).
file(WRITE ${POLYDEM_CLI_WORK}/minimise_one.txt "1 10 10 10\n5 5 5 1\n")
# Two overlapping unit spheres in a periodic box: FIRE pushes them apart to zero energy.
file(WRITE ${POLYDEM_CLI_WORK}/minimise_pair.txt "2 10 10 10\n5 5 5 1\n6.5 5 5 1\n")

polydem_cli_test(NAME minimise_pair COMMAND minimise -i minimise_pair.txt EXIT 0
                 PASS "final +energy 0 +residual 0 +contacts 0 " LABELS minimise)
polydem_cli_test(NAME minimise_pair_hertz COMMAND minimise -i minimise_pair.txt --law hertz EXIT 0
                 PASS "result +no contacts" LABELS minimise)
polydem_cli_test(NAME minimise_one_sphere COMMAND minimise -i minimise_one.txt EXIT 2 PASS "1 sphere. a minimisation needs at least 2"
                 LABELS minimise)
polydem_cli_test(NAME minimise_count_one COMMAND minimise -n 1 EXIT 2 PASS "--count 1: a minimisation needs at least 2"
                 LABELS minimise)
polydem_cli_test(NAME minimise_outer_skin_below_skin COMMAND minimise -n 200 --phi0 0.7 --skin 0.2 --outer-skin 0.1
                 EXIT 2 PASS "outer_skin must be 0 .one level. or >= the skin 0.2, got 0.1" FAIL "FIRE steps" LABELS minimise)
polydem_cli_test(NAME minimise_count_zero COMMAND minimise EXIT 2 PASS "--count 0" LABELS minimise)
polydem_cli_test(NAME minimise_dense COMMAND minimise -n 200 --phi0 0.75 --seed 2 -o minimise_dense.h5 EXIT 0
                 PASS "result +converged" LABELS minimise)
polydem_cli_test(NAME minimise_budget COMMAND minimise -n 200 --phi0 0.75 --max-iterations 20 -o minimise_budget.h5
                 EXIT 4 PASS "not converged: residual [0-9.e+-]+ after 20 iterations" LABELS minimise)
polydem_cli_test(NAME minimise_jam_soft COMMAND minimise -n 128 --phi0 0.6 --target-pressure 1e-4 --progress 0
                 EXIT 0 PASS "phi_J +0\\.6[0-9]+ " LABELS minimise)
polydem_cli_test(NAME minimise_jam_soft_cg COMMAND minimise -n 128 --phi0 0.6 --target-pressure 1e-4 --progress 0
                 --method cg EXIT 0 PASS "minimisations +[0-9]+ .[0-9]+ CG force evaluations." FAIL "FIRE"
                 LABELS minimise)
polydem_cli_test(NAME minimise_method_bad COMMAND minimise -n 20 --method lbfgs EXIT 2 PASS "--method"
                 FAIL "FIRE steps" LABELS minimise)
polydem_cli_test(NAME minimise_jam_soft_budget COMMAND minimise -n 128 --phi0 0.6 --target-pressure 1e-6 --max-steps 2
                 EXIT 4 PASS "step budget: 2 minimisations" LABELS minimise)
# A dense random start in a walled box (size ratio 10): a small sphere is pressed through a wall by a large
# one. The error says so and how to start instead (it said "reduce minimise.dt", which does not help here).
polydem_cli_test(NAME minimise_walls_pressed_through COMMAND minimise --dist uv --omega 10 -n 500 --phi0 0.6
                 --boundary walls --seed 1 --progress 0 EXIT 3
                 PASS "particle id [0-9]+ .r = [0-9.]+. was pressed through the [+-][xyz] wall .* by its contacts"
                 FAIL "carried through|minimise.dt" LABELS minimise)
# Bad options: exit 2, the option named, nothing computed.
polydem_cli_test(NAME minimise_pressure_one COMMAND minimise -n 20 --target-pressure 1 EXIT 2 PASS "--target-pressure"
                 FAIL "FIRE steps" LABELS minimise)
polydem_cli_test(NAME minimise_tolerance_zero COMMAND minimise -n 20 --force-tolerance 0 EXIT 2 PASS "--force-tolerance"
                 LABELS minimise)
polydem_cli_test(NAME minimise_law_bad COMMAND minimise -n 20 --law spring EXIT 2 PASS "--law" LABELS minimise)
polydem_cli_test(NAME minimise_step_without_target COMMAND minimise -n 20 --initial-step 1e-3 EXIT 2
                 PASS "--initial-step needs --target-pressure" LABELS minimise)
polydem_cli_test(NAME minimise_hertz_scaling COMMAND minimise -n 20 --law hertz --stiffness-scaling radius EXIT 2
                 PASS "--stiffness-scaling applies to --law linear" LABELS minimise)
polydem_cli_test(NAME minimise_input_and_count COMMAND minimise -i minimise_pair.txt -n 20 EXIT 2
                 PASS "cannot be combined with --input" LABELS minimise)
polydem_cli_test(NAME minimise_output_is_input COMMAND minimise -i minimise_pair.txt -o minimise_pair.txt EXIT 2
                 PASS "--output" FAIL "FIRE steps" LABELS minimise)
polydem_cli_test(NAME minimise_output_no_dir COMMAND minimise -n 20 -o no_such_dir/x.h5 EXIT 2 PASS "--output"
                 FAIL "FIRE steps" LABELS minimise)
add_test(NAME cli_minimise_nan_options
         COMMAND bash ${CMAKE_CURRENT_SOURCE_DIR}/minimise_nan.sh $<TARGET_FILE:polydem> ${POLYDEM_CLI_WORK})
set_tests_properties(cli_minimise_nan_options PROPERTIES TIMEOUT 60 LABELS "cli;minimise")
add_test(NAME cli_minimise_from_jam_to_analyze
         COMMAND bash ${CMAKE_CURRENT_SOURCE_DIR}/minimise_analyze.sh $<TARGET_FILE:polydem> ${POLYDEM_CLI_WORK})
set_tests_properties(cli_minimise_from_jam_to_analyze PROPERTIES TIMEOUT 120 LABELS "cli;minimise")
add_test(NAME cli_minimise_threads_identical
         COMMAND bash ${CMAKE_CURRENT_SOURCE_DIR}/minimise_threads.sh $<TARGET_FILE:polydem> ${POLYDEM_CLI_WORK})
set_tests_properties(cli_minimise_threads_identical PROPERTIES TIMEOUT 60 LABELS "cli;minimise")
polydem_cli_test(NAME minimise_jam_soft_hertz COMMAND minimise -n 128 --phi0 0.6 --law hertz --target-pressure 1e-4 --progress 0
                 EXIT 0 PASS "result +target reached" LABELS minimise)
add_test(NAME cli_minimise_interrupt
         COMMAND bash ${CMAKE_CURRENT_SOURCE_DIR}/minimise_interrupt.sh $<TARGET_FILE:polydem> ${POLYDEM_CLI_WORK})
set_tests_properties(cli_minimise_interrupt PROPERTIES TIMEOUT 60 LABELS "cli;minimise")
# Scene files (minimise_scene.sh for equivalence, overrides, relative paths and the example's keys; the
# bad-scene classes below: each names the file, the line and the key).
add_test(NAME cli_minimise_scene
         COMMAND bash ${CMAKE_CURRENT_SOURCE_DIR}/minimise_scene.sh $<TARGET_FILE:polydem> ${POLYDEM_CLI_WORK}
                 ${PROJECT_SOURCE_DIR}/examples/minimise_uv10.toml)
set_tests_properties(cli_minimise_scene PROPERTIES TIMEOUT 120 LABELS "cli;minimise")
file(WRITE ${POLYDEM_CLI_WORK}/minimise_scene_unknown.toml "[minimise]\ncount = 20\ntarget_presure = 1e-4\n")
polydem_cli_test(NAME minimise_scene_unknown_key COMMAND minimise minimise_scene_unknown.toml EXIT 2
                 PASS "minimise_scene_unknown.toml: line 3: unknown key minimise.target_presure .valid: .*target_pressure"
                 FAIL "FIRE" LABELS minimise)
file(WRITE ${POLYDEM_CLI_WORK}/minimise_scene_range.toml "[minimise]\ncount = 20\ntarget_pressure = 2.0\n")
polydem_cli_test(NAME minimise_scene_bad_value COMMAND minimise minimise_scene_range.toml EXIT 2
                 PASS "minimise_scene_range.toml: line 3: minimise.target_pressure = 2: " FAIL "FIRE" LABELS minimise)
file(WRITE ${POLYDEM_CLI_WORK}/minimise_scene_type.toml "[minimise]\ncount = [20, 30]\n")
polydem_cli_test(NAME minimise_scene_bad_type COMMAND minimise minimise_scene_type.toml EXIT 2
                 PASS "line 2: minimise.count must be a number or a string" LABELS minimise)
file(WRITE ${POLYDEM_CLI_WORK}/minimise_scene_word.toml "[minimise]\ncount = 20\nlaw = \"spring\"\n")
polydem_cli_test(NAME minimise_scene_bad_choice COMMAND minimise minimise_scene_word.toml EXIT 2
                 PASS "line 3: minimise.law = spring: " LABELS minimise)
file(WRITE ${POLYDEM_CLI_WORK}/minimise_scene_section.toml "[minimise]\ncount = 20\n[relax]\nsteps = 10\n")
polydem_cli_test(NAME minimise_scene_other_section COMMAND minimise minimise_scene_section.toml EXIT 2
                 PASS "line 3: unknown section 'relax'" LABELS minimise)
file(WRITE ${POLYDEM_CLI_WORK}/minimise_scene_empty.toml "count = 20\n")
polydem_cli_test(NAME minimise_scene_no_table COMMAND minimise minimise_scene_empty.toml EXIT 2
                 PASS "unknown key 'count'" LABELS minimise)
file(WRITE ${POLYDEM_CLI_WORK}/minimise_scene_syntax.toml "[minimise]\ncount = = 20\n")
polydem_cli_test(NAME minimise_scene_syntax COMMAND minimise minimise_scene_syntax.toml EXIT 2
                 PASS "minimise_scene_syntax.toml:2:" LABELS minimise)
polydem_cli_test(NAME minimise_scene_missing COMMAND minimise no_such_scene.toml EXIT 2
                 PASS "no_such_scene.toml: cannot open scene file" LABELS minimise)
file(WRITE ${POLYDEM_CLI_WORK}/minimise_scene_self.toml "[minimise]\ncount = 20\noutput = \"minimise_scene_self.toml\"\n")
polydem_cli_test(NAME minimise_scene_output_is_scene COMMAND minimise minimise_scene_self.toml EXIT 2
                 PASS "--output" FAIL "FIRE" LABELS minimise)
# A `polydem jam` input whose phi_j_estimate is not a packing fraction: an input error naming the file and the
# attribute, before any minimisation.
file(WRITE ${POLYDEM_CLI_WORK}/minimise_bad_estimate.txt
     "# attribute: generator = \"polydem jam\"\n# attribute: phi_j_estimate = 1.7\n2 10 10 10\n5 5 5 1\n6.5 5 5 1\n")
polydem_cli_test(NAME minimise_bad_phi_j_estimate COMMAND minimise -i minimise_bad_estimate.txt --target-pressure 1e-4
                 EXIT 2 PASS "minimise_bad_estimate.txt: attribute phi_j_estimate = '1.7' is not a packing fraction"
                 FAIL "minimisations|initial " LABELS minimise)
