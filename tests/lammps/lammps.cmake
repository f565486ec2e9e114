# LAMMPS reproduction (issue 21): polydem relax against the kinetic energies LAMMPS (29 Sep 2021,
# pair_style gran/hooke, fix nve/sphere) recorded in gran_hooke_poly*.log. LAMMPS is not run here.
find_program(POLYDEM_SYSTEM_PYTHON NAMES python3 PATHS /usr/bin NO_DEFAULT_PATH)
if(NOT POLYDEM_SYSTEM_PYTHON)
  find_program(POLYDEM_SYSTEM_PYTHON NAMES python3 REQUIRED)
endif()
set(_lmp ${CMAKE_CURRENT_LIST_DIR}/lammps_reference.sh)
set(_lmp_work ${CMAKE_CURRENT_BINARY_DIR}/lammps)
# Damped (gamma_n = 5000 1/s), dashpot with v(t + dt/2) as LAMMPS: 14.5 digits reached, 12 required.
add_test(NAME lammps_gran_hooke_damped
         COMMAND bash ${_lmp} $<TARGET_FILE:polydem> ${POLYDEM_SYSTEM_PYTHON} ${_lmp_work}/damped
                 gran_hooke_poly.log 12)
# Elastic (gamma_n = 0): 14.4 digits reached, 12 required.
add_test(NAME lammps_gran_hooke_elastic
         COMMAND bash ${_lmp} $<TARGET_FILE:polydem> ${POLYDEM_SYSTEM_PYTHON} ${_lmp_work}/elastic
                 gran_hooke_poly_elastic.log 12 --set contact.gamma_n=0.0)
# Control: polydem's default predicted dashpot velocity agrees to 3.3 digits only (so the test above does
# depend on run.dashpot_velocity = "half-step").
add_test(NAME lammps_gran_hooke_predicted_differs
         COMMAND bash ${_lmp} $<TARGET_FILE:polydem> ${POLYDEM_SYSTEM_PYTHON} ${_lmp_work}/predicted
                 gran_hooke_poly.log 6 --expect-fewer --set run.dashpot_velocity=predicted)
# Friction: gran/hooke/history (xmu = 0.5, Kt = 2/7 Kn) is contact.tangential = "lammps-history":
# 14.5 digits reached without and 14.4 with the tangential dashpot (gamma_t = 2500 1/s = 0.5 gamma_n), 12
# required. polydem's own Cundall-Strack spring with the same constants agrees to 2.5 digits only (lever
# arms r - d/2, spring rotation; docs/lammps.md): 2 required, fewer than 6 expected.
add_test(NAME lammps_gran_hooke_history
         COMMAND bash ${_lmp} $<TARGET_FILE:polydem> ${POLYDEM_SYSTEM_PYTHON} ${_lmp_work}/history
                 gran_hooke_poly_history.log 12 --set contact.friction=0.5 --set contact.tangential=lammps-history)
add_test(NAME lammps_gran_hooke_history_damped
         COMMAND bash ${_lmp} $<TARGET_FILE:polydem> ${POLYDEM_SYSTEM_PYTHON} ${_lmp_work}/history_damped
                 gran_hooke_poly_history_damped.log 12 --set contact.friction=0.5
                 --set contact.tangential=lammps-history --set contact.tangential_damping_ratio=0.5)
add_test(NAME lammps_gran_hooke_history_cundall_strack_approximate
         COMMAND bash ${_lmp} $<TARGET_FILE:polydem> ${POLYDEM_SYSTEM_PYTHON} ${_lmp_work}/history_cs
                 gran_hooke_poly_history.log 2 --set contact.friction=0.5)
add_test(NAME lammps_gran_hooke_history_cundall_strack_differs
         COMMAND bash ${_lmp} $<TARGET_FILE:polydem> ${POLYDEM_SYSTEM_PYTHON} ${_lmp_work}/history_cs_control
                 gran_hooke_poly_history.log 6 --expect-fewer --set contact.friction=0.5)
# The threaded force loop gives the serial results bit for bit, so the same digits with 2 threads.
if(POLYDEM_WITH_OPENMP)
  add_test(NAME lammps_gran_hooke_history_threads
           COMMAND bash ${_lmp} $<TARGET_FILE:polydem> ${POLYDEM_SYSTEM_PYTHON} ${_lmp_work}/history_threads
                   gran_hooke_poly_history.log 12 --set contact.friction=0.5 --set contact.tangential=lammps-history
                   --set run.threads=2)
  set_tests_properties(lammps_gran_hooke_history_threads PROPERTIES TIMEOUT 120 LABELS lammps)
endif()
set_tests_properties(lammps_gran_hooke_damped lammps_gran_hooke_elastic lammps_gran_hooke_predicted_differs
                     lammps_gran_hooke_history lammps_gran_hooke_history_damped
                     lammps_gran_hooke_history_cundall_strack_approximate
                     lammps_gran_hooke_history_cundall_strack_differs
                     PROPERTIES TIMEOUT 120 LABELS lammps)

# Scene keys of the mass-velocity dashpot: every bad or missing value is a ConfigError (exit code 2)
# naming the key, before anything is computed.
set(_scene ${CMAKE_CURRENT_LIST_DIR}/gran_hooke_poly.toml)
function(polydem_lammps_scene_error name pass)
  add_test(NAME lammps_scene_${name}
           COMMAND bash ${PROJECT_SOURCE_DIR}/tests/cli/cli_check.sh 2 "${pass}" "" $<TARGET_FILE:polydem> relax
                   ${ARGN})
  set_tests_properties(lammps_scene_${name} PROPERTIES TIMEOUT 60 LABELS lammps)
endfunction()
polydem_lammps_scene_error(missing_gamma "missing required key contact.gamma_n"
                           ${CMAKE_CURRENT_LIST_DIR}/mass_velocity_no_gamma.toml)
polydem_lammps_scene_error(negative_gamma "contact.gamma_n must be >= 0" ${_scene} --set contact.gamma_n=-1.0)
polydem_lammps_scene_error(text_gamma "contact.gamma_n \\(from --set\\) must be a number" ${_scene}
                           --set contact.gamma_n=fast)
polydem_lammps_scene_error(restitution_too "contact.restitution and contact.damping = \"mass-velocity\" exclude"
                           ${_scene} --set contact.restitution=0.5)
polydem_lammps_scene_error(gamma_without_mass_velocity "contact.gamma_n applies to contact.damping = \"mass-velocity\""
                           ${_scene} --set contact.damping=restitution)
polydem_lammps_scene_error(unknown_damping "contact.damping = \"viscous\" is not valid; expected one of: restitution, mass-velocity"
                           ${_scene} --set contact.damping=viscous)
polydem_lammps_scene_error(hertz_mass_velocity "applies to the linear law only" ${_scene} --set contact.law=hertz)
polydem_lammps_scene_error(unknown_tangential "contact.tangential = \"lammps\" is not valid; expected one of: cundall-strack, lammps-history"
                           ${_scene} --set contact.tangential=lammps)
polydem_lammps_scene_error(hertz_lammps_tangential "contact.tangential = \"lammps-history\" applies to the linear law only"
                           ${CMAKE_CURRENT_LIST_DIR}/mass_velocity_no_gamma.toml --set contact.damping=restitution
                           --set contact.law=hertz --set contact.tangential=lammps-history --set contact.friction=0.5)
polydem_lammps_scene_error(unknown_dashpot_velocity "run.dashpot_velocity = \"full\" is not valid; expected one of: predicted, half-step"
                           ${_scene} --set run.dashpot_velocity=full)
