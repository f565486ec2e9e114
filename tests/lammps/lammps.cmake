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
set_tests_properties(lammps_gran_hooke_damped lammps_gran_hooke_elastic lammps_gran_hooke_predicted_differs
                     PROPERTIES TIMEOUT 120 LABELS lammps)
