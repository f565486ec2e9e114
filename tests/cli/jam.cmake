# polydem jam: CLI tests (issue 15). See cli_helpers.cmake.
# Classes: unreachable targets refused or detected (section 2), exit codes 0/2/4/130, N = 0/1/2, output
# paths checked before the run (section 3), --boundary with --input (section 4), numeric options
# validated (section 5), checkpoint/resume and interrupts (jam_resume.sh, jam_interrupt.sh).

# Small input files, written at configure time into the work directory.
file(WRITE ${POLYDEM_CLI_WORK}/jam_empty.txt "")
file(WRITE ${POLYDEM_CLI_WORK}/jam_zero.txt "0 10 10 10\n")
file(WRITE ${POLYDEM_CLI_WORK}/jam_one_walls.txt "# boundaries: wall wall wall\n1 10 10 10\n5 5 5 1\n")
# 8 unit spheres on a 2 x 2 x 2 lattice of spacing 2.5 (phi 0.27); with and without a boundaries line.
string(CONCAT _lattice "1.25 1.25 1.25 1\n3.75 1.25 1.25 1\n1.25 3.75 1.25 1\n3.75 3.75 1.25 1\n"
                       "1.25 1.25 3.75 1\n3.75 1.25 3.75 1\n1.25 3.75 3.75 1\n3.75 3.75 3.75 1\n")
file(WRITE ${POLYDEM_CLI_WORK}/jam_lattice_periodic.txt
     "# boundaries: periodic periodic periodic\n8 5 5 5\n${_lattice}")
file(WRITE ${POLYDEM_CLI_WORK}/jam_lattice_open.txt "8 5 5 5\n${_lattice}")

set(_fast --schedule 1e-2:1e2,1e-3)

# --- N = 0, 1, 2 -------------------------------------------------------------------------------------
polydem_cli_test(NAME jam_empty_file COMMAND jam -i jam_empty.txt EXIT 2 PASS "jam_empty.txt" LABELS jam)
polydem_cli_test(NAME jam_zero_spheres COMMAND jam -i jam_zero.txt EXIT 2 PASS "0 spheres. a compression needs at least 2"
                 LABELS jam)
polydem_cli_test(NAME jam_one_sphere_walls_file COMMAND jam -i jam_one_walls.txt EXIT 2
                 PASS "1 sphere. a compression needs at least 2" LABELS jam)
polydem_cli_test(NAME jam_one_sphere_walls COMMAND jam -n 1 --boundary walls EXIT 2
                 PASS "--count 1: a compression needs at least 2 spheres" LABELS jam)
polydem_cli_test(NAME jam_two_spheres_periodic COMMAND jam -n 2 EXIT 2 PASS "does not fit 4 times" LABELS jam)
polydem_cli_test(NAME jam_two_spheres_walls COMMAND jam -n 2 --phi0 0.05 --boundary walls ${_fast} --target-pressure 1e6
                 EXIT 0 PASS "target reached +yes" LABELS jam)

# --- unreachable targets: refused before the run -----------------------------------------------------
polydem_cli_test(NAME jam_pressure_beyond_precision COMMAND jam -n 200 --target-pressure 1e15 EXIT 2
                 PASS "target pressure 1e\\+15 is beyond what double precision resolves" FAIL "coll/particle"
                 LABELS jam)
polydem_cli_test(NAME jam_pressure_ideal_gas COMMAND jam -n 50 --target-pressure 2 EXIT 2 PASS "must be finite and > 3"
                 LABELS jam)
polydem_cli_test(NAME jam_rate_absurd COMMAND jam -n 50 --schedule 10 EXIT 2 PASS "growth rate 10 is outside"
                 LABELS jam)
polydem_cli_test(NAME jam_rate_tiny COMMAND jam -n 50 --schedule 1e-12 EXIT 2 PASS "growth rate 1e-12 is outside"
                 LABELS jam)
polydem_cli_test(NAME jam_stage_pressure COMMAND jam -n 50 --schedule 1e-3:0.5,1e-4 EXIT 2 PASS "must be > 1"
                 LABELS jam)
polydem_cli_test(NAME jam_block_tiny COMMAND jam -n 50 --block 1e-6 EXIT 2 PASS "--block 1e-06: must be 0"
                 LABELS jam)
polydem_cli_test(NAME jam_phi0_one COMMAND jam -n 50 --phi0 1 EXIT 2 PASS "phi0" LABELS jam)
polydem_cli_test(NAME jam_count_negative COMMAND jam -n -5 EXIT 2 PASS "count" LABELS jam)
polydem_cli_test(NAME jam_run_collisions_negative COMMAND jam -n 50 --run-collisions -1 EXIT 2 PASS "run-collisions"
                 LABELS jam)
# NaN for every numeric option (a script: the validators echo the offending text, which cli_check's
# no-"nan" rule would reject).
add_test(NAME cli_jam_nan_options
         COMMAND bash ${CMAKE_CURRENT_SOURCE_DIR}/jam_nan.sh $<TARGET_FILE:polydem> ${POLYDEM_CLI_WORK})
set_tests_properties(cli_jam_nan_options PROPERTIES TIMEOUT 60 LABELS "cli;jam")
polydem_cli_test(NAME jam_target_phi_above_one COMMAND jam -n 50 --target-phi 1.5 EXIT 2 PASS "target-phi"
                 LABELS jam)

# --- detected during the run: exit 4, output written and marked --------------------------------------
polydem_cli_test(NAME jam_budget_exhausted
                 COMMAND jam -n 100 --block 1000 --max-collisions 20 -o jam_budget.h5
                 EXIT 4 PASS "collisions +2000 \\(20 per particle\\)" LABELS jam)
polydem_cli_test(NAME jam_target_phi_beyond_jamming
                 COMMAND jam -n 100 ${_fast} --target-phi 0.72 --target-pressure 1e5 -o jam_beyond.txt
                 EXIT 4 PASS "target not reached: jammed before the target packing fraction" LABELS jam)
add_test(NAME cli_jam_marked_output
         COMMAND bash ${CMAKE_CURRENT_SOURCE_DIR}/jam_marked.sh $<TARGET_FILE:polydem> ${POLYDEM_CLI_WORK})
set_tests_properties(cli_jam_marked_output PROPERTIES TIMEOUT 120 LABELS "cli;jam")

# --- outputs checked before any computation ----------------------------------------------------------
polydem_cli_test(NAME jam_output_no_directory COMMAND jam -n 300 -o nodir/x.h5 EXIT 2 PASS "nodir"
                 FAIL "random sequential addition:|coll/particle" LABELS jam)
polydem_cli_test(NAME jam_eos_no_directory COMMAND jam -n 300 --eos-csv nodir/eos.csv EXIT 2 PASS "--eos-csv"
                 FAIL "random sequential addition:|coll/particle" LABELS jam)
polydem_cli_test(NAME jam_checkpoint_no_directory COMMAND jam -n 300 --checkpoint nodir/c.h5 EXIT 2 PASS "--checkpoint"
                 FAIL "random sequential addition:|coll/particle" LABELS jam)
polydem_cli_test(NAME jam_output_is_input COMMAND jam -i jam_lattice_open.txt -o jam_lattice_open.txt EXIT 2
                 PASS "-o/--output" LABELS jam)
polydem_cli_test(NAME jam_outputs_alias COMMAND jam -n 300 -o jam_alias.h5 --checkpoint jam_alias.h5 EXIT 2
                 PASS "the same file as another output" LABELS jam)
polydem_cli_test(NAME jam_interval_without_checkpoint COMMAND jam -n 50 --checkpoint-interval 5 EXIT 2
                 PASS "--checkpoint-interval needs --checkpoint" LABELS jam)

# --- --boundary with --input: takes effect where the file is silent, refused where it conflicts -------
polydem_cli_test(NAME jam_boundary_conflict COMMAND jam -i jam_lattice_periodic.txt --boundary walls EXIT 2
                 PASS "--boundary walls conflicts with the boundaries of jam_lattice_periodic.txt" LABELS jam)
polydem_cli_test(NAME jam_boundary_takes_effect
                 COMMAND jam -i jam_lattice_open.txt --boundary walls ${_fast} --target-pressure 1e4
                 EXIT 0 PASS "box walled 5 x 5 x 5" LABELS jam)
polydem_cli_test(NAME jam_boundary_agrees
                 COMMAND jam -i jam_lattice_periodic.txt --boundary periodic --block 10 --max-collisions 30
                 EXIT 4 PASS "box periodic" LABELS jam)

# --- resume ------------------------------------------------------------------------------------------
polydem_cli_test(NAME jam_resume_missing COMMAND jam --resume jam_no_such_checkpoint.h5 EXIT 2
                 PASS "jam_no_such_checkpoint.h5" LABELS jam)
polydem_cli_test(NAME jam_resume_conflict COMMAND jam --resume jam_no_such_checkpoint.h5 -n 5 EXIT 2
                 PASS "--count cannot be combined with --resume" LABELS jam)
add_test(NAME cli_jam_resume
         COMMAND bash ${CMAKE_CURRENT_SOURCE_DIR}/jam_resume.sh $<TARGET_FILE:polydem> ${POLYDEM_CLI_WORK})
set_tests_properties(cli_jam_resume PROPERTIES TIMEOUT 300 LABELS "cli;jam;slow")
add_test(NAME cli_jam_interrupt
         COMMAND bash ${CMAKE_CURRENT_SOURCE_DIR}/jam_interrupt.sh $<TARGET_FILE:polydem> ${POLYDEM_CLI_WORK})
set_tests_properties(cli_jam_interrupt PROPERTIES TIMEOUT 300 LABELS "cli;jam;slow")

# --- --reopen reads the file's reduced_pressure strictly (io::numericAttribute) ----------------------
add_test(NAME cli_jam_reopen_attribute
         COMMAND bash ${CMAKE_CURRENT_SOURCE_DIR}/jam_reopen_attribute.sh $<TARGET_FILE:polydem> ${POLYDEM_CLI_WORK})
set_tests_properties(cli_jam_reopen_attribute PROPERTIES TIMEOUT 120 LABELS "cli;jam")

# --- a resumed run's report: this session's time and rate, and the time over all sessions (session 33) ----
add_test(NAME cli_jam_resume_sessions
         COMMAND bash ${CMAKE_CURRENT_SOURCE_DIR}/jam_resume_sessions.sh $<TARGET_FILE:polydem> ${POLYDEM_CLI_WORK})
set_tests_properties(cli_jam_resume_sessions PROPERTIES TIMEOUT 120 LABELS "cli;jam")

# --- resume of a wide distribution: the size-class skin floors are in the checkpoint (issue 24) ---------
add_test(NAME cli_jam_resume_wide
         COMMAND bash ${CMAKE_CURRENT_SOURCE_DIR}/jam_resume_wide.sh $<TARGET_FILE:polydem> ${POLYDEM_CLI_WORK})
set_tests_properties(cli_jam_resume_wide PROPERTIES TIMEOUT 120 LABELS "cli;jam")
