# Building this package with pip (scikit-build-core) from the ros-jazzy-* wheels instead of a
# ROS install. Included by CMakeLists.txt only when SKBUILD is set; `colcon build` never reads it.
#
# The wheels install like a ROS install whose prefix is the Python environment that pip builds
# in (share/<pkg>/cmake, share/ament_index, include/, lib/), with three gaps this file closes:
#   1. under scikit-build-core the install prefix is a staging folder, so ament finds neither
#      the CMake packages nor the rosidl typesupports ("No 'rosidl_typesupport_c' found")
#      unless CMAKE_PREFIX_PATH and the AMENT_PREFIX_PATH environment variable name that prefix;
#   2. the generated Python package must land in site-packages (scikit-build's platlib dir),
#      while libraries and share/ go to the environment's prefix (wheel.install-dir = "/data");
#   3. the exported *__rosidl_generator_py targets of the wheels carry the include paths of the
#      container the wheels were built in (its Python and numpy headers), which do not exist
#      here; CMake's generate step fails on them. They are pointed at this interpreter's.

function(_densepack_python out code)
  execute_process(
    COMMAND "${Python_EXECUTABLE}" -c "${code}"
    OUTPUT_VARIABLE value ERROR_VARIABLE error RESULT_VARIABLE status
    OUTPUT_STRIP_TRAILING_WHITESPACE)
  if(NOT status EQUAL 0)
    message(FATAL_ERROR "densepack_interfaces: '${Python_EXECUTABLE} -c ${code}' failed: ${error}")
  endif()
  set(${out} "${value}" PARENT_SCOPE)
endfunction()

macro(densepack_pip_prepare)
  if(NOT Python_EXECUTABLE)
    message(FATAL_ERROR "densepack_interfaces: scikit-build-core did not pass Python_EXECUTABLE")
  endif()
  # The prefix the ROS wheels were installed into (pip's build environment): the package
  # rosidl_pycommon lives in <prefix>/lib/pythonX.Y/site-packages.
  _densepack_python(DENSEPACK_ROS_PREFIX
    "import pathlib, rosidl_pycommon; print(pathlib.Path(rosidl_pycommon.__file__).resolve().parents[4])")
  if(NOT EXISTS "${DENSEPACK_ROS_PREFIX}/share/ament_index/resource_index")
    message(FATAL_ERROR "densepack_interfaces: no ament index under ${DENSEPACK_ROS_PREFIX}; "
      "are the ros-jazzy-* build wheels of pyproject.toml installed?")
  endif()
  message(STATUS "densepack_interfaces: ROS wheels prefix ${DENSEPACK_ROS_PREFIX}")
  list(PREPEND CMAKE_PREFIX_PATH "${DENSEPACK_ROS_PREFIX}")
  if(DEFINED ENV{AMENT_PREFIX_PATH} AND NOT "$ENV{AMENT_PREFIX_PATH}" STREQUAL "")
    set(ENV{AMENT_PREFIX_PATH} "${DENSEPACK_ROS_PREFIX}:$ENV{AMENT_PREFIX_PATH}")
  else()
    set(ENV{AMENT_PREFIX_PATH} "${DENSEPACK_ROS_PREFIX}")
  endif()
  # ament_cmake_python keeps a PYTHON_INSTALL_DIR that is already defined.
  set(PYTHON_INSTALL_DIR "${SKBUILD_PLATLIB_DIR}")
  _densepack_python(DENSEPACK_PYTHON_INCLUDE
    "import sysconfig; print(sysconfig.get_paths()['include'])")
  _densepack_python(DENSEPACK_NUMPY_INCLUDE "import numpy; print(numpy.get_include())")
endmacro()

function(densepack_pip_fix_include_dirs)
  # (3) Imported targets of this directory whose include paths do not exist on this machine.
  get_directory_property(imported IMPORTED_TARGETS)
  foreach(target IN LISTS imported)
    get_target_property(dirs ${target} INTERFACE_INCLUDE_DIRECTORIES)
    if(NOT dirs)
      continue()
    endif()
    set(fixed "")
    set(changed FALSE)
    foreach(dir IN LISTS dirs)
      if(NOT IS_ABSOLUTE "${dir}" OR EXISTS "${dir}")
        list(APPEND fixed "${dir}")
        continue()
      endif()
      set(changed TRUE)
      if(dir MATCHES "/numpy/")
        list(APPEND fixed "${DENSEPACK_NUMPY_INCLUDE}")
      elseif(dir MATCHES "/include/python[0-9.]+$")
        list(APPEND fixed "${DENSEPACK_PYTHON_INCLUDE}")
      else()
        message(STATUS "densepack_interfaces: ${target}: dropping missing include dir ${dir}")
      endif()
    endforeach()
    if(changed)
      list(REMOVE_DUPLICATES fixed)
      set_target_properties(${target} PROPERTIES INTERFACE_INCLUDE_DIRECTORIES "${fixed}")
    endif()
  endforeach()

  # Our own Python typesupport target exports the same kind of paths (pip's build environment
  # is deleted after the build): keep them to the build tree, out of the installed export.
  set(own "${PROJECT_NAME}__rosidl_generator_py")
  if(TARGET ${own})
    get_target_property(dirs ${own} INTERFACE_INCLUDE_DIRECTORIES)
    set(wrapped "")
    foreach(dir IN LISTS dirs)
      if(IS_ABSOLUTE "${dir}")
        list(APPEND wrapped "$<BUILD_INTERFACE:${dir}>")
      else()
        list(APPEND wrapped "${dir}")
      endif()
    endforeach()
    set_target_properties(${own} PROPERTIES INTERFACE_INCLUDE_DIRECTORIES "${wrapped}")
  endif()
endfunction()

function(densepack_pip_drop_egg_info)
  # ament_python_install_package (called by rosidl_generator_py) writes an egg-info named like
  # this distribution next to pip's own dist-info: two metadata records for one name. Install
  # rules run in the order given, so this one, declared last, removes it before the wheel is
  # packed.
  install(CODE "
    file(GLOB _eggs \"${PYTHON_INSTALL_DIR}/${PROJECT_NAME}-*.egg-info\")
    if(_eggs)
      file(REMOVE_RECURSE \${_eggs})
    endif()
  ")
endfunction()
