# CTest include file (see tests/CMakeLists.txt): the GoogleTest cases that take 10 s or more in a Release
# build get the label `slow`, which scripts/run-checked-tests.sh skips. Each is listed with its reason.
foreach(test
    # EDMD compressions to p = 1e12 that are then certified (LPs): 15-30 s each.
    Compression.SmallMonodispersePackingJamsIsostatic
    Compression.SmallBidispersePackingJams
    Compression.ResumedRunIsBitIdentical
    # Brute-force comparison at 20,000 spheres over every hand-set level count.
    HGridAgreement.UniformVolumeHandSetSizesMatchBruteForce
    # Counts heap allocations over a long DEM run (the sanitizers replace the allocator anyway).
    TimeLoop.DoesNotAllocateOnceSized
    VerletList.ThreadedRebuildsDoNotAllocateOnceSized)
  if(NOT "${test}" STREQUAL "")
    set_tests_properties(${test} PROPERTIES LABELS slow)
  endif()
endforeach()
