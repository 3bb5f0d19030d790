# One bounded fuzz run for ctest (fuzz_core_<profile>): cmake -DFUZZER=... -DWORK=... -DCORPUS=...
# -DSECONDS=... -P run_fuzz.cmake. WORK is emptied first, so every run starts from the committed
# seed corpus alone and takes the same time whatever earlier runs found; new inputs and any
# crash (crash-*, with the input that broke an invariant) are left in WORK.
foreach(var FUZZER WORK CORPUS SECONDS)
  if(NOT DEFINED ${var})
    message(FATAL_ERROR "run_fuzz.cmake: -D${var}= is required")
  endif()
endforeach()
file(REMOVE_RECURSE ${WORK})
file(MAKE_DIRECTORY ${WORK}/new)
execute_process(
  COMMAND ${FUZZER} -max_total_time=${SECONDS} -seed=1 -jobs=1 -workers=1 -print_final_stats=1
          -artifact_prefix=${WORK}/ ${WORK}/new ${CORPUS}
  RESULT_VARIABLE result)
if(NOT result EQUAL 0)
  file(GLOB crashes ${WORK}/crash-* ${WORK}/leak-* ${WORK}/timeout-* ${WORK}/oom-*)
  message(FATAL_ERROR "${FUZZER} failed (${result}); input: ${crashes}\n"
                      "reproduce: ${FUZZER} <that file>")
endif()
