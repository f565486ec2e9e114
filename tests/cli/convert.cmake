# polydem convert (issue 21): formats, round trips, inputs never overwritten, bad inputs with exit code 2.
add_test(NAME cli_convert_cases
         COMMAND bash ${CMAKE_CURRENT_SOURCE_DIR}/convert_cases.sh $<TARGET_FILE:polydem> ${POLYDEM_CLI_WORK}/convert)
set_tests_properties(cli_convert_cases PROPERTIES TIMEOUT 120 LABELS "cli;convert")
polydem_cli_test(NAME convert_needs_two COMMAND convert only_one.txt EXIT 2 PASS "give IN OUT")
polydem_cli_test(NAME convert_missing_input COMMAND convert no_such_file.data out.h5 EXIT 2
                 PASS "no_such_file.data: no such file")
polydem_cli_test(NAME convert_bad_format COMMAND convert a.txt b.h5 --to xyz EXIT 2 PASS "--to")
polydem_cli_test(NAME convert_series_not_xmf COMMAND convert --series s.h5 a.h5 EXIT 2 PASS "must end in .xmf")
# relax output.arrays (issue 21): unknown names and snapshots that cannot hold arrays are scene errors.
polydem_cli_test(NAME relax_arrays_unknown COMMAND relax relax_small.toml -q --set output.snapshot=\"a_{step}.h5\"
                 --set output.arrays=[\"force\",\"bogus\"] EXIT 2 PASS "output.arrays: unknown array \"bogus\"" LABELS relax)
polydem_cli_test(NAME relax_arrays_data_snapshot COMMAND relax relax_small.toml -q --set output.snapshot=\"a_{step}.data\"
                 --set output.arrays=[\"force\"] EXIT 2 PASS "is a LAMMPS data file, which has no columns" LABELS relax)
# relax output.contacts (issue 21): off unless asked for, needs a snapshot, a boolean, a file of its own.
polydem_cli_test(NAME relax_contacts_without_snapshot COMMAND relax relax_small.toml -q --set output.contacts=true
                 EXIT 2 PASS "output.contacts = true writes one contact file beside every snapshot" LABELS relax)
polydem_cli_test(NAME relax_contacts_not_boolean COMMAND relax relax_small.toml -q --set output.snapshot=\"c_{step}.h5\"
                 --set output.contacts=\"yes\" EXIT 2 PASS "must be true or false" LABELS relax)
polydem_cli_test(NAME relax_contacts_file_is_final COMMAND relax relax_small.toml -q --set output.snapshot=\"c_{step}.txt\"
                 --set output.contacts=true --set output.final=\"c_000000000_contacts.csv\" EXIT 2
                 PASS "output.final and output.contacts \\(the contact file\\) are the same file" LABELS relax)
polydem_cli_test(NAME relax_arrays_unknown_lists_new COMMAND relax relax_small.toml -q --set output.snapshot=\"a_{step}.h5\"
                 --set output.arrays=[\"rattlers\"] EXIT 2 PASS "kinetic_energy, rattler, size_class" LABELS relax)
polydem_cli_test(NAME minimise_contacts_without_output COMMAND minimise -n 20 --contacts EXIT 2
                 PASS "--contacts writes the contact file beside the packing: give -o FILE too" LABELS minimise)
