# Finds Python and pybind11 for the Python module (python/). Included at the top level so that
# the imported targets are visible to python/ and tests/python/. Sets DDOC_PYTHON_MODULE_BUILT.
#
# The interpreter the module is built for and the tests run with: Debian's by default (a pyenv
# shim earlier on PATH would otherwise win); override with -DPython_EXECUTABLE=...
if(NOT DEFINED Python_EXECUTABLE AND EXISTS /usr/bin/python3)
  set(Python_EXECUTABLE /usr/bin/python3)
endif()
find_package(Python 3 COMPONENTS Interpreter Development.Module QUIET)
set(PYBIND11_FINDPYTHON ON)
if(Python_FOUND)
  find_package(pybind11 CONFIG QUIET)
endif()
if(Python_FOUND AND pybind11_FOUND)
  set(DDOC_PYTHON_MODULE_BUILT ON)
  set(DDOC_PYTHON_DIR ${CMAKE_BINARY_DIR}/python)
  set(DDOC_PYTHON_EXECUTABLE ${Python_EXECUTABLE})
else()
  set(DDOC_PYTHON_MODULE_BUILT OFF)
  message(STATUS "ddoc: Python 3 development files or pybind11 not found; the Python module is "
                 "not built (apt-get install python3-dev pybind11-dev python3-pybind11)")
endif()
