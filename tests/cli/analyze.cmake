# polydem analyze: CLI tests (issue 15). See cli_helpers.cmake.
# polydem_cli_test(NAME name COMMAND args... [EXIT code] [PASS regex] [FAIL regex] [LABELS l...] [TIMEOUT s])
# Runs `polydem args...` through cli_check.sh, which asserts the exit code and, if given, that the
# combined stdout+stderr matches PASS and does not match FAIL. Work files go to ${POLYDEM_CLI_WORK}.
#
# Verdicts only where they apply: an inflated FCC packing (overlapping, above pi/sqrt(18)) is refused
# naming the worst pair; N = 0, 1, 2 and dilute gases get reports without nan, "hyperstatic" or "jammed";
# a file without reduced_pressure needs --pressure or --contact-gap; a malformed attribute is named; every
# numeric option is validated; no output may alias the input. Inputs come from analyze_inputs.sh.
set(_analyze_in ${POLYDEM_CLI_WORK}/analyze)
add_test(NAME cli_analyze_inputs
         COMMAND bash ${CMAKE_CURRENT_SOURCE_DIR}/analyze_inputs.sh $<TARGET_FILE:polydem> ${_analyze_in})
set_tests_properties(cli_analyze_inputs PROPERTIES FIXTURES_SETUP cli_analyze_inputs TIMEOUT 120 LABELS cli)

function(analyze_cli_test name)
  polydem_cli_test(NAME analyze_${name} ${ARGN})
  set_tests_properties(cli_analyze_${name} PROPERTIES FIXTURES_REQUIRED cli_analyze_inputs)
endfunction()
# A verdict would be "jammed" not preceded by "un"; "hyperstatic" needs a non-empty backbone.
set(_vacuous "hyperstatic|(^|[^n])jammed")

# Invalid packings: refused before any statistics (today both jamming tests certify this one jammed).
analyze_cli_test(fcc_inflated_refused
  COMMAND analyze ${_analyze_in}/fcc_inflated.txt --pressure 1e6 --certify --leak-test 100
  EXIT 2
  PASS "fcc_inflated.txt: not a valid hard-sphere packing: spheres [0-9]+ and [0-9]+ overlap by 0.0198 of the smaller radius \\(worst of 648 overlaps beyond the contact tolerance 1.0e-04\\); packing fraction 0.76291779 exceeds 0.74048049"
  FAIL "ideal-contact LP|jamming test \\(loads\\)|pressure-leak test|^packing fraction")
analyze_cli_test(fcc_inflated_density
  COMMAND analyze ${_analyze_in}/fcc_inflated.txt --contact-gap 0.05 --certify
  EXIT 2
  PASS "packing fraction 0.76291779 exceeds 0.74048049, the largest any packing of these radii can have \\(FCC density pi/sqrt\\(18\\) for equal spheres\\); worst overlap: spheres [0-9]+ and [0-9]+ overlap by 0.0198"
  FAIL "ideal-contact LP|jamming test \\(loads\\)")
analyze_cli_test(small_box_refused
  COMMAND analyze ${_analyze_in}/fcc_one_cell.txt --pressure 1e12 --certify
  EXIT 2 PASS "fcc_one_cell.txt: the box is too small for the contact network" FAIL "LP test|\\(loads\\)")
analyze_cli_test(fcc_inflated_structure_only
  COMMAND analyze ${_analyze_in}/fcc_inflated.txt --structure-only --order
  PASS "bond order \\(l = 6\\) +p_c = 1.0000")

# N = 0, 1, 2 and gases: what is true, "undefined" where nothing is.
analyze_cli_test(empty_report
  COMMAND analyze ${_analyze_in}/empty.txt --pressure 1e6 --certify --leak-test 100
  PASS "jamming test \\(loads\\) +not tested: no spheres" FAIL "${_vacuous}")
analyze_cli_test(empty_gap
  COMMAND analyze ${_analyze_in}/empty.txt --pressure 1e6
  PASS "smallest gap +undefined \\(fewer than two spheres\\)" FAIL "${_vacuous}")
analyze_cli_test(empty_coordination
  COMMAND analyze ${_analyze_in}/empty.txt --pressure 1e6
  PASS "contacts \\(gap <= 1.0e-04\\) 0  z = undefined \\(no spheres\\)" FAIL "${_vacuous}")
analyze_cli_test(empty_z_csv_refused
  COMMAND analyze ${_analyze_in}/empty.txt --pressure 1e6 --z-csv analyze_empty_z.csv
  EXIT 2 PASS "--z-csv: .*empty.txt has no spheres, so Z\\(tau\\) .* is undefined")
analyze_cli_test(one_report
  COMMAND analyze ${_analyze_in}/one.txt --pressure 1e6 --certify --leak-test 100
  PASS "pressure-leak test +not tested: a single sphere collides with nothing" FAIL "${_vacuous}")
analyze_cli_test(one_isostaticity
  COMMAND analyze ${_analyze_in}/one.txt --pressure 1e6
  PASS "isostaticity +undefined \\(empty backbone: every sphere is a rattler\\)" FAIL "${_vacuous}")
analyze_cli_test(one_gr_refused
  COMMAND analyze ${_analyze_in}/one.txt --pressure 1e6 --gr-csv analyze_one_g.csv
  EXIT 2 PASS "--gr-csv: .*one.txt has 1 sphere, so g\\(x\\) .* is undefined")
analyze_cli_test(two_gap
  COMMAND analyze ${_analyze_in}/two.txt --pressure 1e6 --certify
  PASS "smallest gap +1.5 \\(relative to r_i \\+ r_j; negative = overlap\\), spheres 0 and 1" FAIL "${_vacuous}")
analyze_cli_test(two_backbone
  COMMAND analyze ${_analyze_in}/two.txt --pressure 1e6 --certify
  PASS "backbone +0 spheres, 0 contacts, z = undefined \\(empty backbone\\)" FAIL "${_vacuous}")
analyze_cli_test(gas_gap
  COMMAND analyze ${_analyze_in}/gas.txt --pressure 1e6
  PASS "smallest gap +0\\.0[0-9]+ \\(relative to r_i \\+ r_j; negative = overlap\\), spheres [0-9]+ and [0-9]+"
  FAIL "smallest gap +0 |${_vacuous}")
analyze_cli_test(gas_certify_leak
  COMMAND analyze ${_analyze_in}/gas.txt --pressure 1e6 --certify --leak-test 100
  PASS "pressure-leak test +not tested: every sphere is a rattler" FAIL "${_vacuous}")
analyze_cli_test(gas_phi_j
  COMMAND analyze ${_analyze_in}/gas.h5 --pressure 1e6
  PASS "phi_J estimate undefined: empty backbone" FAIL "${_vacuous}")
add_test(NAME cli_analyze_degenerate
         COMMAND bash ${CMAKE_CURRENT_SOURCE_DIR}/analyze_degenerate.sh $<TARGET_FILE:polydem> ${_analyze_in})
set_tests_properties(cli_analyze_degenerate PROPERTIES FIXTURES_REQUIRED cli_analyze_inputs TIMEOUT 300
                     LABELS "cli;slow")

# No assumed pressure; attributes parsed strictly.
analyze_cli_test(text_needs_pressure
  COMMAND analyze ${_analyze_in}/two.txt --certify
  EXIT 2
  PASS "two.txt has no reduced_pressure attribute, .*give --pressure P .* or --contact-gap TAU"
  FAIL "^packing fraction")
analyze_cli_test(h5_needs_pressure
  COMMAND analyze ${_analyze_in}/gas.h5
  EXIT 2 PASS "gas.h5 has no reduced_pressure attribute")
analyze_cli_test(contact_gap_without_pressure
  COMMAND analyze ${_analyze_in}/two.txt --contact-gap 1e-4
  PASS "reduced pressure +unknown \\(no reduced_pressure attribute, no --pressure\\): phi_J estimate undefined")
add_test(NAME cli_analyze_attribute
         COMMAND bash ${CMAKE_CURRENT_SOURCE_DIR}/analyze_attribute.sh $<TARGET_FILE:polydem> ${_analyze_in})
set_tests_properties(cli_analyze_attribute PROPERTIES FIXTURES_REQUIRED cli_analyze_inputs TIMEOUT 120
                     SKIP_RETURN_CODE 77 LABELS cli)

# Numeric options (--loads 0 among them) and option combinations.
add_test(NAME cli_analyze_bad_options
         COMMAND bash ${CMAKE_CURRENT_SOURCE_DIR}/analyze_bad_options.sh $<TARGET_FILE:polydem> ${_analyze_in})
set_tests_properties(cli_analyze_bad_options PROPERTIES FIXTURES_REQUIRED cli_analyze_inputs TIMEOUT 120
                     LABELS cli)

# Outputs: checked before any work, never the input, never each other.
analyze_cli_test(output_is_input
  COMMAND analyze ${_analyze_in}/jam30.h5 --z-csv ${_analyze_in}/jam30.h5
  EXIT 2 PASS "--z-csv '.*jam30.h5': is the input" FAIL "^packing fraction")
analyze_cli_test(motion_output_is_input
  COMMAND analyze ${_analyze_in}/jam30.h5 --certify --motion-csv ${_analyze_in}/jam30.h5
  EXIT 2 PASS "--motion-csv '.*jam30.h5': is the input" FAIL "^packing fraction")
analyze_cli_test(output_directory_missing
  COMMAND analyze ${_analyze_in}/jam30.h5 --gr-csv analyze_nodir/g.csv
  EXIT 2 PASS "--gr-csv 'analyze_nodir/g.csv': directory 'analyze_nodir' does not exist" FAIL "^packing fraction")
analyze_cli_test(outputs_alias
  COMMAND analyze ${_analyze_in}/jam30.h5 --z-csv analyze_same.csv --sk-csv ./analyze_same.csv
  EXIT 2 PASS "--sk-csv './analyze_same.csv': is also the file of --z-csv" FAIL "^packing fraction")
analyze_cli_test(outputs_written
  COMMAND analyze ${_analyze_in}/jam30.h5 --z-csv analyze_z.csv --gr-csv analyze_g.csv --gr-max 1.3
  PASS "wrote analyze_g.csv" FAIL "error")
