# polydem relax on MPI ranks (issue 20, docs/parallel.md), label `mpi`: the final state, time series and final
# checkpoint of mpirun -np 1..4 (oversubscribed on small machines) are byte-identical to the serial run's, for
# a frictional scene with walls across gravity and a periodic polydisperse one (size ratio 10); checkpoints
# resume on another rank count; unsupported features are refused. Each run takes seconds.
set(POLYDEM_MPI_WORK ${CMAKE_CURRENT_BINARY_DIR}/mpi-work)
file(MAKE_DIRECTORY ${POLYDEM_MPI_WORK})
# Frictional, polydisperse (size ratio 4), walls across gravity: tests/determinism/relax_reference.toml with a
# time series, 600 steps.
file(READ ${CMAKE_CURRENT_SOURCE_DIR}/determinism/relax_reference.toml _polydem_mpi_walls)
string(REPLACE "final = \"relax_reference_final.txt\"" "timeseries_interval = 50" _polydem_mpi_walls
               "${_polydem_mpi_walls}")
string(REPLACE "steps = 1500" "steps = 600" _polydem_mpi_walls "${_polydem_mpi_walls}")  # seconds per test
file(WRITE ${POLYDEM_MPI_WORK}/mpi_walls.toml "${_polydem_mpi_walls}")
# Periodic, frictionless with damping, uniform-volume sizes with size ratio 10: large ghosts.
file(WRITE ${POLYDEM_MPI_WORK}/mpi_periodic.toml "[particles]
count = 1500
distribution = \"uniform-volume\"
rmin = 1e-3
omega = 10.0
packing_fraction = 0.4
density = 2500.0
seed = 3
[contact]
stiffness = 1e4
restitution = 0.8
[velocities]
overlap = 0.02
[run]
steps = 500
check_interval = 100
progress_interval = 0.0
[output]
timeseries_interval = 50
")
# Periodic and frictional (Cundall-Strack springs and rotation across ranks), mono.
file(WRITE ${POLYDEM_MPI_WORK}/mpi_friction.toml "[particles]
count = 800
distribution = \"uniform-radius\"
rmin = 1e-3
omega = 1.5
packing_fraction = 0.38
density = 2500.0
seed = 11
[contact]
stiffness = 1e4
restitution = 0.5
friction = 0.5
tangential_damping_ratio = 0.5
[velocities]
overlap = 0.02
[run]
steps = 400
check_interval = 50
progress_interval = 0.0
[output]
timeseries_interval = 100
")

# A dilute gas whose storage order decays: the serial run re-sorts (DemSettings::resort, measured every 500
# steps) between steps 3500 and 5000, which renumbers the slots the ranks key their particles by.
file(WRITE ${POLYDEM_MPI_WORK}/mpi_gas.toml "# expects re-sorts (tests/mpi/mpi_compare.sh)
[particles]
count = 2100
distribution = \"uniform-radius\"
rmin = 1e-3
omega = 2.0
packing_fraction = 0.05
density = 2500.0
seed = 3
[contact]
stiffness = 1e4
restitution = 0.95
[velocities]
overlap = 0.08
[run]
steps = 6000
check_interval = 1000
progress_interval = 0.0
[output]
timeseries_interval = 500
")

# Soft compression (radii growing under viscous damping, builds between steps as the radii grow) from packing
# 0.3 to 0.5, then 800 steps of the run: periodic, uniform volume of size ratio 4.
file(WRITE ${POLYDEM_MPI_WORK}/mpi_compress.toml "[particles]
count = 1200
distribution = \"uniform-volume\"
rmin = 1e-3
omega = 4.0
packing_fraction = 0.3
density = 2500.0
seed = 7
[contact]
stiffness = 1e4
restitution = 0.7
[velocities]
overlap = 0.02
[compression]
packing_fraction = 0.5
growth_rate = 0.02
[run]
steps = 800
check_interval = 100
progress_interval = 0.0
[output]
timeseries_interval = 100
")

# Hertz with Hertz-Mindlin friction, viscous damping, half-step dashpot velocity, walls across gravity.
string(REPLACE "stiffness = 1e4" "law = \"hertz\"\nstiffness = 1e8\ntangential = \"hertz-mindlin\"\npoisson_ratio = 0.3"
               _polydem_mpi_hertz "${_polydem_mpi_walls}")
string(REPLACE "check_interval = 100" "check_interval = 100\nviscous_damping = 20.0\ndashpot_velocity = \"half-step\""
               _polydem_mpi_hertz "${_polydem_mpi_hertz}")
file(WRITE ${POLYDEM_MPI_WORK}/mpi_hertz.toml "${_polydem_mpi_hertz}")

set(_polydem_mpi ${MPIEXEC_EXECUTABLE})
# On 2 busy cores a run of 2-4 ranks takes 10-25 s (every wait for a message gives the core away): one rank
# count per scene runs in the checked passes, the others are labelled slow too.
set(_polydem_mpi_quick mpi_walls_np2 mpi_periodic_np3 mpi_friction_np4 mpi_hertz_np3 mpi_gas_np2 mpi_compress_np3)
foreach(scene walls periodic friction hertz gas compress)
  add_test(NAME mpi_${scene}_serial
           COMMAND bash ${CMAKE_CURRENT_SOURCE_DIR}/mpi/mpi_compare.sh $<TARGET_FILE:polydem> ${_polydem_mpi}
                   ${POLYDEM_MPI_WORK} mpi_${scene}.toml serial -q)
  set_tests_properties(mpi_${scene}_serial PROPERTIES FIXTURES_SETUP mpi_${scene} TIMEOUT 120 LABELS mpi)
  foreach(np 1 2 3 4)
    add_test(NAME mpi_${scene}_np${np}
             COMMAND bash ${CMAKE_CURRENT_SOURCE_DIR}/mpi/mpi_compare.sh $<TARGET_FILE:polydem> ${_polydem_mpi}
                     ${POLYDEM_MPI_WORK} mpi_${scene}.toml ${np} -q)
    set(_labels mpi)
    if(NOT mpi_${scene}_np${np} IN_LIST _polydem_mpi_quick)
      set(_labels "mpi;slow")
    endif()
    set_tests_properties(mpi_${scene}_np${np} PROPERTIES FIXTURES_REQUIRED mpi_${scene} TIMEOUT 120 LABELS "${_labels}")
  endforeach()
endforeach()
# The brick grid instead of the (default) cost-weighted recursive coordinate bisection: the same bytes.
foreach(scene walls periodic)
  add_test(NAME mpi_${scene}_np3_brick
           COMMAND bash ${CMAKE_CURRENT_SOURCE_DIR}/mpi/mpi_compare.sh $<TARGET_FILE:polydem> ${_polydem_mpi}
                   ${POLYDEM_MPI_WORK} mpi_${scene}.toml 3 -q --decomposition brick)
  set_tests_properties(mpi_${scene}_np3_brick PROPERTIES FIXTURES_REQUIRED mpi_${scene} TIMEOUT 120 LABELS "mpi;slow")
endforeach()
# OpenMP threads inside each rank: the same bytes.
if(POLYDEM_WITH_OPENMP)
  add_test(NAME mpi_walls_np2_threads2
           COMMAND bash ${CMAKE_CURRENT_SOURCE_DIR}/mpi/mpi_compare.sh $<TARGET_FILE:polydem> ${_polydem_mpi}
                   ${POLYDEM_MPI_WORK} mpi_walls.toml 2 -q --threads 2)
  set_tests_properties(mpi_walls_np2_threads2 PROPERTIES FIXTURES_REQUIRED mpi_walls TIMEOUT 120 LABELS "mpi;slow")
endif()
add_test(NAME mpi_resume_other_ranks
         COMMAND bash ${CMAKE_CURRENT_SOURCE_DIR}/mpi/mpi_resume.sh $<TARGET_FILE:polydem> ${_polydem_mpi}
                 ${POLYDEM_MPI_WORK} mpi_walls.toml 600)
set_tests_properties(mpi_resume_other_ranks PROPERTIES FIXTURES_REQUIRED mpi_walls TIMEOUT 180 LABELS mpi)
add_test(NAME mpi_refuse_unsupported
         COMMAND bash ${CMAKE_CURRENT_SOURCE_DIR}/mpi/mpi_refuse.sh $<TARGET_FILE:polydem> ${_polydem_mpi}
                 ${POLYDEM_MPI_WORK})
set_tests_properties(mpi_refuse_unsupported PROPERTIES TIMEOUT 120 LABELS mpi)
# polydem minimise on ranks (parallel::DistributedFire): the packing file and the report's results are the serial
# run's byte for byte. Pressure-controlled jamming (11 minimisations, radii scaled between them, about 50,000
# FIRE steps) of a periodic uniform-volume packing of 800 spheres of size ratio 10; one minimisation of a
# walled bidisperse packing with Hertz contacts after a change of phi (the Hertz masses, wall contacts across
# ranks).
file(WRITE ${POLYDEM_MPI_WORK}/mpi_min_jam.toml "[minimise]
dist = \"uniform-volume\"
omega = 10.0
count = 800
phi0 = 0.7
seed = 2
target_pressure = 1e-2
progress = 0.0
")
file(WRITE ${POLYDEM_MPI_WORK}/mpi_min_walls.toml "[minimise]
dist = \"bi\"
omega = 3.0
count = 900
phi0 = 0.45
boundary = \"walls\"
law = \"hertz\"
seed = 5
delta_phi = 0.01
progress = 0.0
")
# The checked pass (which skips `slow`) runs FIRE across ranks in mpi_min_walls_np3 and the pressure protocol
# across ranks in mpi_min_jam_cg_np2 (below); the FIRE protocol's mpi_min_jam_np2 and _serial (39 s and 28 s
# under the sanitizers, 8 s and 5 s in Release) run in the Release pass only.
set(_polydem_mpi_min_quick mpi_min_walls_np3)
foreach(scene min_jam min_walls)
  add_test(NAME mpi_${scene}_serial
           COMMAND bash ${CMAKE_CURRENT_SOURCE_DIR}/mpi/mpi_minimise.sh $<TARGET_FILE:polydem> ${_polydem_mpi}
                   ${POLYDEM_MPI_WORK} mpi_${scene}.toml serial)
  set(_labels mpi)
  if(scene STREQUAL "min_jam")
    set(_labels "mpi;slow")
  endif()
  set_tests_properties(mpi_${scene}_serial PROPERTIES FIXTURES_SETUP mpi_${scene} TIMEOUT 120 LABELS "${_labels}")
  foreach(np 1 2 3 4)
    add_test(NAME mpi_${scene}_np${np}
             COMMAND bash ${CMAKE_CURRENT_SOURCE_DIR}/mpi/mpi_minimise.sh $<TARGET_FILE:polydem> ${_polydem_mpi}
                     ${POLYDEM_MPI_WORK} mpi_${scene}.toml ${np})
    set(_labels mpi)
    if(NOT mpi_${scene}_np${np} IN_LIST _polydem_mpi_min_quick)
      set(_labels "mpi;slow")
    endif()
    set_tests_properties(mpi_${scene}_np${np} PROPERTIES FIXTURES_REQUIRED mpi_${scene} TIMEOUT 180 LABELS "${_labels}")
  endforeach()
endforeach()
# Conjugate gradients on ranks: one minimisation of an over-compressed packing (phi 0.8, uniform-volume, size
# ratio 10; about 4,000 evaluations), on 2 ranks in every build and on 3 in the full one; and the pressure
# protocol of mpi_min_jam with --method cg (11 minimisations, about 26,000 evaluations) on 2 ranks.
file(WRITE ${POLYDEM_MPI_WORK}/mpi_min_cg.toml "[minimise]
dist = \"uniform-volume\"
omega = 10.0
count = 1500
phi0 = 0.8
seed = 2
method = \"cg\"
progress = 0.0
")
add_test(NAME mpi_min_cg_serial
         COMMAND bash ${CMAKE_CURRENT_SOURCE_DIR}/mpi/mpi_minimise.sh $<TARGET_FILE:polydem> ${_polydem_mpi}
                 ${POLYDEM_MPI_WORK} mpi_min_cg.toml serial)
set_tests_properties(mpi_min_cg_serial PROPERTIES FIXTURES_SETUP mpi_min_cg TIMEOUT 120 LABELS mpi)
foreach(np 2 3)
  add_test(NAME mpi_min_cg_np${np}
           COMMAND bash ${CMAKE_CURRENT_SOURCE_DIR}/mpi/mpi_minimise.sh $<TARGET_FILE:polydem> ${_polydem_mpi}
                   ${POLYDEM_MPI_WORK} mpi_min_cg.toml ${np})
  set(_labels "mpi;slow")
  if(np EQUAL 2)
    set(_labels mpi)
  endif()
  set_tests_properties(mpi_min_cg_np${np} PROPERTIES FIXTURES_REQUIRED mpi_min_cg TIMEOUT 180 LABELS "${_labels}")
endforeach()
add_test(NAME mpi_min_jam_cg_serial
         COMMAND bash ${CMAKE_CURRENT_SOURCE_DIR}/mpi/mpi_minimise.sh $<TARGET_FILE:polydem> ${_polydem_mpi}
                 ${POLYDEM_MPI_WORK} mpi_min_jam.toml serial --method cg)
set_tests_properties(mpi_min_jam_cg_serial PROPERTIES FIXTURES_SETUP mpi_min_jam_cg TIMEOUT 120 LABELS mpi)
add_test(NAME mpi_min_jam_cg_np2
         COMMAND bash ${CMAKE_CURRENT_SOURCE_DIR}/mpi/mpi_minimise.sh $<TARGET_FILE:polydem> ${_polydem_mpi}
                 ${POLYDEM_MPI_WORK} mpi_min_jam.toml 2 --method cg)
set_tests_properties(mpi_min_jam_cg_np2 PROPERTIES FIXTURES_REQUIRED mpi_min_jam_cg TIMEOUT 180 LABELS mpi)
if(POLYDEM_WITH_OPENMP)
  add_test(NAME mpi_min_walls_np2_threads2
           COMMAND bash ${CMAKE_CURRENT_SOURCE_DIR}/mpi/mpi_minimise.sh $<TARGET_FILE:polydem> ${_polydem_mpi}
                   ${POLYDEM_MPI_WORK} mpi_min_walls.toml 2 --threads 2)
  set_tests_properties(mpi_min_walls_np2_threads2 PROPERTIES FIXTURES_REQUIRED mpi_min_walls TIMEOUT 180
                       LABELS "mpi;slow")
endif()
# The determinism reference scene (tests/determinism) on 3 ranks: its checked-in SHA-256.
add_test(NAME mpi_determinism_reference_np3
         COMMAND bash ${CMAKE_CURRENT_SOURCE_DIR}/mpi/mpi_reference.sh $<TARGET_FILE:polydem> ${_polydem_mpi}
                 ${POLYDEM_MPI_WORK} 3)
set_tests_properties(mpi_determinism_reference_np3 PROPERTIES TIMEOUT 180 LABELS "mpi;slow")
# Several ranks need the cores to themselves: OpenMPI's waiting ranks poll (yielding), so a rank that waits for
# one descheduled by another test's process loses a scheduler slice per message. Beside a Debug+ASan build's
# other tests, 2-rank runs of a few seconds took minutes (and a CI run timed out). So every test that starts
# more than one rank runs alone.
get_property(_polydem_mpi_tests DIRECTORY PROPERTY TESTS)
foreach(_test IN LISTS _polydem_mpi_tests)
  if(_test MATCHES "^mpi_" AND NOT _test MATCHES "_(serial|np1)$")
    set_tests_properties(${_test} PROPERTIES RUN_SERIAL TRUE)
  endif()
endforeach()
