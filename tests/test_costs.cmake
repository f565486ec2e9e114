# Scheduling hints for CTest (the COST property): on a clean clone CTest has no timings of its own and starts
# the tests in the order they are defined, so a pass used to end with long tests running one after another
# (session 26's fresh-clone CI: the checked pass took 682 s for 878 s of tests on two cores). With COST set,
# `ctest -j` starts the dearest first. The seconds are in tests/test_cost_data.cmake, written by
# scripts/test-costs.sh from measured passes.
#
# Read twice: at configure time by each directory that adds tests with add_test() (polydem_apply_test_costs(),
# for the tests of that directory), and at test time as a CTest include file (for the GoogleTest cases, which
# exist only once discovered; there set_tests_properties() passes over names it does not know).
include(${CMAKE_CURRENT_LIST_DIR}/test_cost_data.cmake)
if(CMAKE_GENERATOR)
  function(polydem_apply_test_costs)
    get_property(_tests DIRECTORY PROPERTY TESTS)
    set(_data ${POLYDEM_TEST_COST_DATA})
    while(_data)
      list(POP_FRONT _data _name _seconds)
      if(_name IN_LIST _tests)
        set_tests_properties(${_name} PROPERTIES COST ${_seconds})
      endif()
    endwhile()
  endfunction()
else()
  set(_polydem_data ${POLYDEM_TEST_COST_DATA})
  while(_polydem_data)
    list(POP_FRONT _polydem_data _polydem_name _polydem_seconds)
    set_tests_properties(${_polydem_name} PROPERTIES COST ${_polydem_seconds})
  endwhile()
endif()
