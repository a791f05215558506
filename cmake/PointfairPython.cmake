# The Python module (python/): pybind11 and NumPy from Debian's packages (pybind11-dev,
# python3-numpy, python3-dev). POINTFAIR_PYTHON defaults on when they are found.
#
# The interpreter is the first of Python3_EXECUTABLE (if given), `python3` on the PATH and
# /usr/bin/python3 that imports numpy: a python3 earlier on the PATH without NumPy (pyenv, a
# virtual environment) does not hide Debian's.
set(pointfair_python_found OFF)
set(pointfair_python_candidates)
if(Python3_EXECUTABLE)
  list(APPEND pointfair_python_candidates "${Python3_EXECUTABLE}")
else()
  find_program(pointfair_path_python3 NAMES python3)
  if(pointfair_path_python3)
    list(APPEND pointfair_python_candidates "${pointfair_path_python3}")
  endif()
  if(EXISTS /usr/bin/python3)
    list(APPEND pointfair_python_candidates /usr/bin/python3)
  endif()
endif()
foreach(candidate IN LISTS pointfair_python_candidates)
  execute_process(COMMAND "${candidate}" -c "import numpy"
    RESULT_VARIABLE numpy_result OUTPUT_QUIET ERROR_QUIET)
  if(numpy_result EQUAL 0)
    set(Python3_EXECUTABLE "${candidate}" CACHE FILEPATH "Python interpreter of the pointfair module" FORCE)
    break()
  endif()
endforeach()
if(numpy_result EQUAL 0)
  # Python first: pybind11 then takes it (FindPython) rather than probing on its own.
  find_package(Python3 COMPONENTS Interpreter Development.Module QUIET)
  if(Python3_FOUND AND Python3_Development.Module_FOUND)
    find_package(pybind11 2.6 CONFIG QUIET)
    if(pybind11_FOUND)
      set(pointfair_python_found ON)
    endif()
  endif()
endif()

option(POINTFAIR_PYTHON "Build the Python module pointfair (pybind11, NumPy)" ${pointfair_python_found})
if(POINTFAIR_PYTHON AND NOT pointfair_python_found)
  message(FATAL_ERROR "POINTFAIR_PYTHON needs pybind11, Python 3 headers and NumPy "
    "(Debian: pybind11-dev python3-dev python3-numpy)")
endif()
# Where `cmake --install` puts the package, relative to the prefix: Debian's folder for
# Python 3 packages (on the path of /usr/bin/python3 for the prefix /usr).
set(POINTFAIR_PYTHON_INSTALL_DIR "lib/python3/dist-packages" CACHE STRING
  "Install folder of the Python package pointfair, relative to the prefix")
if(POINTFAIR_PYTHON)
  message(STATUS "pointfair: Python module for ${Python3_EXECUTABLE} (${Python3_VERSION})")
endif()
