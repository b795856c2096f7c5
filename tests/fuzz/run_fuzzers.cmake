# Runs every fuzz target for SECONDS seconds on a copy of its seed corpus (the copy collects what
# the fuzzer finds, so the repository's corpus stays as committed). Fails on the first finding.
#   cmake -DFUZZ_DIR=<dir of the fuzz_* binaries> -DCORPUS=<tests/fuzz/corpus>
#         -DWORK=<scratch dir> -DSECONDS=7 -P run_fuzzers.cmake
foreach(kind obj off ply om medit tetgen handles pp mlx)
  set(exe ${FUZZ_DIR}/fuzz_${kind})
  if(NOT EXISTS ${exe})
    message(FATAL_ERROR "fuzz: ${exe} was not built")
  endif()
  file(REMOVE_RECURSE ${WORK}/${kind})
  file(MAKE_DIRECTORY ${WORK}/${kind}/corpus ${WORK}/${kind}/artifacts)
  file(GLOB seeds ${CORPUS}/${kind}/*)
  file(COPY ${seeds} DESTINATION ${WORK}/${kind}/corpus)
  execute_process(
    COMMAND ${exe} -max_total_time=${SECONDS} -timeout=10 -rss_limit_mb=2048
            -malloc_limit_mb=256 -print_final_stats=1
            -artifact_prefix=${WORK}/${kind}/artifacts/ ${WORK}/${kind}/corpus
    RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  string(REGEX MATCH "stat::number_of_executed_units: *[0-9]+" runs "${err}")
  message(STATUS "fuzz_${kind}: ${runs}")
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "fuzz_${kind} found a problem (exit ${rc}); the input is in "
                        "${WORK}/${kind}/artifacts/\n${err}")
  endif()
endforeach()
