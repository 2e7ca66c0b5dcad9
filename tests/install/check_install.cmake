# Installs the sid build tree to a fresh prefix, then configures, builds and runs a consumer
# project that only knows find_package(sid), in both build modes.
file(REMOVE_RECURSE ${WORK_DIR})
set(prefix ${WORK_DIR}/prefix)
execute_process(COMMAND ${CMAKE_COMMAND} --install ${SID_BINARY_DIR} --prefix ${prefix}
                RESULT_VARIABLE rc)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "cmake --install failed: ${rc}")
endif()
execute_process(COMMAND ${CMAKE_COMMAND} -S ${CONSUMER_SOURCE_DIR} -B ${WORK_DIR}/build
                        -DCMAKE_PREFIX_PATH=${prefix} -DCMAKE_BUILD_TYPE=Release
                        # -O1: the header-only consumer's compile time is the template front
                        # end's; -O3 would add 12 s to it.
                        "-DCMAKE_CXX_FLAGS_RELEASE=-O1 -DNDEBUG"
                        -DSID_WITH_CVODE=${SID_WITH_CVODE}
                RESULT_VARIABLE rc)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "configuring the consumer against the installed sid failed: ${rc}")
endif()
execute_process(COMMAND ${CMAKE_COMMAND} --build ${WORK_DIR}/build RESULT_VARIABLE rc)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "building the consumer failed: ${rc}")
endif()
foreach(mode IN ITEMS header_only compiled)
  execute_process(COMMAND ${WORK_DIR}/build/consumer_${mode} RESULT_VARIABLE rc OUTPUT_VARIABLE out)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "the ${mode} consumer failed: ${rc} ${out}")
  endif()
  message(STATUS "${mode} consumer says: ${out}")
endforeach()
