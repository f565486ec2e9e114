# polydem_target_defaults(<target>): language level, warnings, include root, optimisation flags.
function(polydem_target_defaults target)
  target_compile_features(${target} PUBLIC cxx_std_20)
  target_include_directories(${target} PUBLIC ${PROJECT_SOURCE_DIR} ${PROJECT_BINARY_DIR}/include)
  target_compile_options(${target} PRIVATE -Wall -Wextra -Wundef -Wno-deprecated-declarations)
  # No fused multiply-add contraction: every backend evaluates the pair predicate with identical
  # rounding, which is what lets the property suite demand bit-identical pair sets.
  target_compile_options(${target} PUBLIC -ffp-contract=off)
  if(POLYDEM_NATIVE)
    target_compile_options(${target} PUBLIC -march=native)
  endif()
  if(POLYDEM_SANITIZE)
    # Every UB report is fatal (no recovery), so a sanitizer finding fails its test.
    target_compile_options(${target} PUBLIC -fsanitize=address,undefined -fno-sanitize-recover=undefined
                                            -fno-omit-frame-pointer)
    target_link_options(${target} PUBLIC -fsanitize=address,undefined)
  endif()
  if(POLYDEM_ENABLE_ASSERTS)
    target_compile_definitions(${target} PUBLIC POLYDEM_ENABLE_ASSERTS=1)
  endif()
endfunction()
