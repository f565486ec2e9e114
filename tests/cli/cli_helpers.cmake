# polydem_cli_test(NAME name COMMAND args... [EXIT code] [PASS regex] [FAIL regex] [LABELS l...] [TIMEOUT s])
# Runs `polydem args...` through cli_check.sh, which asserts the exit code and, if given, that the
# combined stdout+stderr matches PASS and does not match FAIL. Work files go to ${POLYDEM_CLI_WORK}.
set(POLYDEM_CLI_WORK ${CMAKE_CURRENT_BINARY_DIR}/work)
file(MAKE_DIRECTORY ${POLYDEM_CLI_WORK})
function(polydem_cli_test)
  cmake_parse_arguments(T "" "NAME;EXIT;PASS;FAIL;TIMEOUT" "COMMAND;LABELS" ${ARGN})
  if(NOT DEFINED T_EXIT)
    set(T_EXIT 0)
  endif()
  if(NOT DEFINED T_TIMEOUT)
    set(T_TIMEOUT 120)
  endif()
  add_test(NAME cli_${T_NAME}
           COMMAND bash ${CMAKE_CURRENT_SOURCE_DIR}/cli_check.sh "${T_EXIT}" "${T_PASS}" "${T_FAIL}"
                   $<TARGET_FILE:polydem> ${T_COMMAND}
           WORKING_DIRECTORY ${POLYDEM_CLI_WORK})
  set_tests_properties(cli_${T_NAME} PROPERTIES TIMEOUT ${T_TIMEOUT} LABELS "cli;${T_LABELS}")
endfunction()
