# Runs a benchmark with arguments that must be refused before any timing (ctest, via -P):
# ARGS (split as a shell would) must exit with CODE and print a line matching EXPECT.
separate_arguments(args UNIX_COMMAND "${ARGS}")
execute_process(COMMAND ${EXE} ${args} RESULT_VARIABLE rc OUTPUT_VARIABLE out
                ERROR_VARIABLE err TIMEOUT 20)
if(NOT rc STREQUAL CODE)
  message(FATAL_ERROR "${EXE} ${ARGS}: exit ${rc}, expected ${CODE}\n${out}${err}")
endif()
if(NOT "${out}${err}" MATCHES "${EXPECT}")
  message(FATAL_ERROR "${EXE} ${ARGS}: no line matching '${EXPECT}' in\n${out}${err}")
endif()
