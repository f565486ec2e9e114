# polydem lammps-neighbor (issue 21): LAMMPS neighbor multi lines from the HGrid cost model. Options are
# checked before the file is read (any.txt need not exist); bad files: lammps_neighbor.sh.
add_test(NAME cli_lammps_neighbor_lines
         COMMAND bash ${CMAKE_CURRENT_SOURCE_DIR}/lammps_neighbor.sh $<TARGET_FILE:polydem>
                 ${POLYDEM_CLI_WORK}/lammps_neighbor)
set_tests_properties(cli_lammps_neighbor_lines PROPERTIES TIMEOUT 120 LABELS "cli;lammps_neighbor")
polydem_cli_test(NAME lammps_neighbor_missing_file COMMAND lammps-neighbor no_such_file.txt EXIT 2
                 PASS "no_such_file.txt" LABELS lammps_neighbor)
polydem_cli_test(NAME lammps_neighbor_bad_pair COMMAND lammps-neighbor any.txt --pair lj/cut EXIT 2
                 PASS "--pair must be granular or gran/hooke" LABELS lammps_neighbor)
polydem_cli_test(NAME lammps_neighbor_bad_format COMMAND lammps-neighbor any.txt --format xml EXIT 2
                 PASS "--format must be text or lines" LABELS lammps_neighbor)
polydem_cli_test(NAME lammps_neighbor_negative_skin COMMAND lammps-neighbor any.txt --skin -1
                 EXIT 2 PASS "--skin" LABELS lammps_neighbor)
polydem_cli_test(NAME lammps_neighbor_nan_skin COMMAND lammps-neighbor any.txt --skin nan EXIT 2
                 PASS "--skin" LABELS lammps_neighbor)
