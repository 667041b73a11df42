# Installs the ddoc build tree to a temporary prefix, configures and builds the external
# consumer project against it with find_package(ddoc), and runs it.
# Inputs: BUILD_DIR, SOURCE_DIR (consumer sources), WORK_DIR, CONFIG; CONSUMER_CXX and
# CONSUMER_FLAGS (compiler and flags of a sanitizer build, empty otherwise).
file(REMOVE_RECURSE ${WORK_DIR})
file(MAKE_DIRECTORY ${WORK_DIR})
function(run)
  execute_process(COMMAND ${ARGN} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "command failed (${rc}): ${ARGN}\n${out}\n${err}")
  endif()
  message("${out}")
endfunction()
run(${CMAKE_COMMAND} --install ${BUILD_DIR} --prefix ${WORK_DIR}/prefix --component ddoc_dev)
foreach(header ddoc/ddoc.h ddoc/trial_driver.h ddoc/hopper/hopper_learning.h)
  if(NOT EXISTS ${WORK_DIR}/prefix/include/${header})
    message(FATAL_ERROR "${header} was not installed")
  endif()
endforeach()
set(consumer_options)
if(CONSUMER_CXX)
  list(APPEND consumer_options -DCMAKE_CXX_COMPILER=${CONSUMER_CXX}
       "-DCMAKE_CXX_FLAGS=${CONSUMER_FLAGS}" "-DCMAKE_EXE_LINKER_FLAGS=${CONSUMER_FLAGS}")
endif()
run(${CMAKE_COMMAND} -S ${SOURCE_DIR} -B ${WORK_DIR}/build -DCMAKE_BUILD_TYPE=${CONFIG}
    -DCMAKE_PREFIX_PATH=${WORK_DIR}/prefix ${consumer_options})
run(${CMAKE_COMMAND} --build ${WORK_DIR}/build)
run(${WORK_DIR}/build/consumer)
run(${WORK_DIR}/build/hopper_settings)
