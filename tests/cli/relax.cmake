# polydem relax: CLI tests (issue 15). See cli_helpers.cmake.
# Small scenes are written into the work folder at configure time; every test runs in ${POLYDEM_CLI_WORK}.

# A frictional scene with walls across gravity: every feature whose state a checkpoint must carry.
set(RELAX_SCENE_BODY "[particles]
count = 300
distribution = \"uniform-radius\"
rmin = 1e-3
omega = 2.0
packing_fraction = 0.3
density = 2500.0
[box]
boundaries = [\"periodic\", \"periodic\", \"wall\"]
[contact]
stiffness = 1e4
restitution = 0.7
friction = 0.5
[run]
steps = 400
gravity = [0.0, 0.0, -9.81]
check_interval = 50
progress_interval = 0.0
")
file(WRITE ${POLYDEM_CLI_WORK}/relax_small.toml "${RELAX_SCENE_BODY}")
# Periodic and frictionless, for the guards that need no walls.
file(WRITE ${POLYDEM_CLI_WORK}/relax_gas.toml "[particles]
count = 200
distribution = \"mono\"
rmin = 1e-3
packing_fraction = 0.2
[contact]
stiffness = 1e4
[run]
steps = 100
progress_interval = 0.0
")
# Particle files: empty, one sphere, two spheres, a duplicate centre, a text file with its own boundaries.
file(WRITE ${POLYDEM_CLI_WORK}/relax_n0.txt "0 10 10 10\n")
file(WRITE ${POLYDEM_CLI_WORK}/relax_n1.txt "# boundaries: wall wall wall\n1 10 10 10\n5 5 5 1\n")
file(WRITE ${POLYDEM_CLI_WORK}/relax_n2.txt "# boundaries: wall wall wall\n2 10 10 10\n3 5 5 1 1 0 0\n7 5 5 1 -1 0 0\n")
file(WRITE ${POLYDEM_CLI_WORK}/relax_coincident.txt "3 10 10 10\n2 2 2 1\n2 2 2 1\n7 7 7 1\n")
foreach(n n0 n1 n2 coincident)
  file(WRITE ${POLYDEM_CLI_WORK}/relax_file_${n}.toml "[particles]
file = \"relax_${n}.txt\"
[contact]
stiffness = 1e4
[velocities]
initial = \"zero\"
[run]
steps = 50
progress_interval = 0.0
[output]
final = \"relax_file_${n}_final.txt\"
")
endforeach()
file(WRITE ${POLYDEM_CLI_WORK}/relax_file_conflict.toml "[particles]
file = \"relax_n2.txt\"
[box]
boundaries = \"periodic\"
[contact]
stiffness = 1e4
[run]
steps = 10
")

set(R relax relax_small.toml -q)

# Section 4: defaults.
polydem_cli_test(NAME relax_print_defaults COMMAND relax --print-defaults
                 PASS "broadphase = \"auto\"" LABELS relax)
polydem_cli_test(NAME relax_default_broadphase_is_auto COMMAND relax relax_gas.toml -q --steps 10
                 PASS "broad phase: auto" LABELS relax)
polydem_cli_test(NAME relax_boundaries_conflict_with_file COMMAND relax relax_file_conflict.toml
                 EXIT 2 PASS "box.boundaries = \"periodic,periodic,periodic\" conflicts with .*relax_n2.txt" LABELS relax)

# Section 3: outputs checked before any computation (FAIL: nothing was started).
polydem_cli_test(NAME relax_final_in_missing_dir COMMAND ${R} --set output.final=\"nodir/x.txt\"
                 EXIT 2 PASS "output.final" FAIL "particles:|relax report" LABELS relax)
polydem_cli_test(NAME relax_timeseries_is_scene COMMAND ${R} --set output.timeseries=\"relax_small.toml\"
                 EXIT 2 PASS "output.timeseries" FAIL "particles:|relax report" LABELS relax)
polydem_cli_test(NAME relax_final_is_particle_input COMMAND relax relax_file_n2.toml --set output.final=\"relax_n2.txt\"
                 EXIT 2 PASS "output.final" FAIL "particles:|relax report" LABELS relax)
polydem_cli_test(NAME relax_checkpoint_in_missing_dir COMMAND ${R} --set output.checkpoint=\"nodir/c.h5\"
                 EXIT 2 PASS "output.checkpoint" FAIL "particles:|relax report" LABELS relax)
polydem_cli_test(NAME relax_snapshot_in_missing_dir COMMAND ${R} --set output.snapshot=\"nodir/s_{step}.txt\"
                 EXIT 2 PASS "output.snapshot" FAIL "particles:|relax report" LABELS relax)
polydem_cli_test(NAME relax_two_outputs_one_file
                 COMMAND ${R} --set output.final=\"same.txt\" --set output.timeseries=\"same.txt\"
                 EXIT 2 PASS "same file" FAIL "particles:|relax report" LABELS relax)

# Section 5: guards.
polydem_cli_test(NAME relax_unstable_dt_refused COMMAND relax relax_gas.toml -q --set run.dt=1e-3
                 EXIT 2 PASS "run.dt = 0.001 s is t_c,min / .*run.allow_unstable_dt" LABELS relax)
polydem_cli_test(NAME relax_unstable_dt_allowed_blows_up
                 COMMAND relax relax_gas.toml -q --set run.dt=2e-3 --set run.allow_unstable_dt=true --steps 2000
                 EXIT 3 PASS "simulation error: step .*the run blew up. Likely cause: run.dt = " FAIL "wrap periodic|run.dt_factor f >=" LABELS relax)
polydem_cli_test(NAME relax_final_check_with_check_interval_zero
                 COMMAND relax relax_gas.toml -q --set run.dt=2e-3 --set run.allow_unstable_dt=true --steps 2000
                         --set run.check_interval=0
                 EXIT 3 PASS "simulation error: step 2000" LABELS relax)
polydem_cli_test(NAME relax_gravity_fully_periodic COMMAND relax relax_gas.toml -q --set "run.gravity=[0,0,-9.81]"
                 EXIT 2 PASS "fully periodic" LABELS relax)
polydem_cli_test(NAME relax_impact_hint_names_overlap
                 COMMAND relax relax_gas.toml -q --set velocities.overlap=0.6 --steps 2000 --set run.check_interval=10
                 EXIT 3 PASS "lower velocities.overlap" FAIL "stiffness >=" LABELS relax)
polydem_cli_test(NAME relax_coincident_particles COMMAND relax relax_file_coincident.toml -q
                 EXIT 2 PASS "coincident" LABELS relax)
polydem_cli_test(NAME relax_scene_nan COMMAND relax relax_gas.toml -q --set run.viscous_damping=nan
                 EXIT 2 PASS "run.viscous_damping .*must be a finite number, got not-a-number" LABELS relax)
polydem_cli_test(NAME relax_scene_negative_seed COMMAND relax relax_gas.toml -q --set particles.seed=-3
                 EXIT 2 PASS "particles.seed must be >= 0" LABELS relax)
polydem_cli_test(NAME relax_sweep_trailing_garbage COMMAND relax relax_gas.toml -q --sweep dt-factor=10,20x
                 EXIT 2 PASS "--sweep dt-factor: '20x' is not a finite number" LABELS relax)
polydem_cli_test(NAME relax_sweep_nan COMMAND relax relax_gas.toml -q --sweep skin=nan
                 EXIT 2 PASS "--sweep skin: value 1 \\(not-a-number or infinite\\) is not a finite number" LABELS relax)
polydem_cli_test(NAME relax_sweep_negative COMMAND relax relax_gas.toml -q --sweep skin=-1e-4
                 EXIT 2 PASS "--sweep skin: -1e-4 is below" LABELS relax)
polydem_cli_test(NAME relax_sweep_empty_item COMMAND relax relax_gas.toml -q --sweep dt-factor=10,,20
                 EXIT 2 PASS "--sweep dt-factor: '' is not a finite number" LABELS relax)

polydem_cli_test(NAME relax_sweep_writes_table COMMAND relax relax_gas.toml -q --sweep dt-factor=20,50 --steps 100
                 PASS "table: relax_gas_sweep_dt-factor.csv" LABELS relax)

# N = 0, 1, 2: a clear error or an honest report.
polydem_cli_test(NAME relax_n0 COMMAND relax relax_file_n0.toml -q EXIT 2 PASS "no particles" LABELS relax)
polydem_cli_test(NAME relax_n1 COMMAND relax relax_file_n1.toml -q PASS "relative change undefined" LABELS relax)
polydem_cli_test(NAME relax_n2 COMMAND relax relax_file_n2.toml -q --set velocities.initial=\"file\"
                 PASS "relax report" LABELS relax)

# Exit code 4: a soft compression that ends before its target writes its output, marked.
polydem_cli_test(NAME relax_compression_target_not_reached
                 COMMAND relax relax_gas.toml -q --set compression.packing_fraction=0.9
                         --set compression.max_steps=2000 --set output.final=\"relax_not_reached.h5\"
                 EXIT 4 PASS "TARGET NOT REACHED +soft compression: compression.max_steps = 2000 spent" LABELS relax)

# Multi-step tests: numeric options, resume byte for byte, SIGINT.
foreach(script relax_options relax_resume relax_interrupt relax_compress_resume relax_boundaries)
  add_test(NAME cli_${script} COMMAND bash ${CMAKE_CURRENT_SOURCE_DIR}/${script}.sh $<TARGET_FILE:polydem>
           ${POLYDEM_CLI_WORK}/${script})
  set_tests_properties(cli_${script} PROPERTIES TIMEOUT 300 LABELS "cli;relax")
endforeach()
set_property(TEST cli_relax_compress_resume APPEND PROPERTY LABELS slow)
