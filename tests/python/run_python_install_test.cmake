# Installs the Python package (component ddoc_python) of the build tree into a temporary prefix and
# imports it from there with PYTHONPATH=PREFIX/PYDIR only (install_check.py, run from an empty
# directory, so that nothing of the build or source tree is on the path).
# Inputs: BUILD_DIR, WORK_DIR, PYDIR (DDOC_PYTHON_INSTALL_DIR), PYTHON, CHECK (install_check.py).
file(REMOVE_RECURSE ${WORK_DIR})
file(MAKE_DIRECTORY ${WORK_DIR}/cwd)
execute_process(COMMAND ${CMAKE_COMMAND} --install ${BUILD_DIR} --prefix ${WORK_DIR}/prefix
                        --component ddoc_python
                RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "cmake --install failed (${rc}):\n${out}\n${err}")
endif()
execute_process(COMMAND ${CMAKE_COMMAND} -E env --unset=PYTHONPATH
                        PYTHONPATH=${WORK_DIR}/prefix/${PYDIR}
                        ${PYTHON} ${CHECK} ${WORK_DIR}/prefix
                WORKING_DIRECTORY ${WORK_DIR}/cwd
                RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
message("${out}")
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "the installed package failed (${rc}):\n${out}\n${err}")
endif()
