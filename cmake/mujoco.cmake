# MuJoCo, from the `mujoco` wheel that scripts/setup installs into the project's .venv: the
# wheel ships libmujoco.so.<version> (no unversioned symlink) and include/mujoco/*.h. The
# imported target mujoco::mujoco links that file by its full path, with an rpath to its folder.
set(AX12_VENV_PYTHON ${CMAKE_SOURCE_DIR}/.venv/bin/python CACHE FILEPATH
    "The Python of the project's environment, whose mujoco package holds libmujoco")
execute_process(
  COMMAND ${AX12_VENV_PYTHON} -c
          "import importlib.util as u; s = u.find_spec('mujoco'); print(s.submodule_search_locations[0])"
  OUTPUT_VARIABLE AX12_MUJOCO_DIR RESULT_VARIABLE found OUTPUT_STRIP_TRAILING_WHITESPACE ERROR_QUIET)
if(NOT found EQUAL 0 OR NOT AX12_MUJOCO_DIR)
  message(FATAL_ERROR "MuJoCo: no mujoco package in ${AX12_VENV_PYTHON}'s environment: run scripts/setup")
endif()
file(GLOB AX12_MUJOCO_LIBRARY ${AX12_MUJOCO_DIR}/libmujoco.so.*)
list(LENGTH AX12_MUJOCO_LIBRARY count)
if(NOT count EQUAL 1 OR NOT EXISTS ${AX12_MUJOCO_DIR}/include/mujoco/mujoco.h)
  message(FATAL_ERROR "MuJoCo: ${AX12_MUJOCO_DIR} holds no single libmujoco.so.<version> with include/mujoco/mujoco.h")
endif()
get_filename_component(soname ${AX12_MUJOCO_LIBRARY} NAME)
add_library(mujoco::mujoco SHARED IMPORTED)
set_target_properties(mujoco::mujoco PROPERTIES
  IMPORTED_LOCATION ${AX12_MUJOCO_LIBRARY}
  IMPORTED_SONAME ${soname}
  INTERFACE_INCLUDE_DIRECTORIES ${AX12_MUJOCO_DIR}/include
  INTERFACE_SYSTEM_INCLUDE_DIRECTORIES ${AX12_MUJOCO_DIR}/include
  INTERFACE_LINK_OPTIONS "-Wl,-rpath,${AX12_MUJOCO_DIR}")
# A new wheel (scripts/setup after a version change) configures again.
set_property(DIRECTORY ${CMAKE_SOURCE_DIR} APPEND PROPERTY CMAKE_CONFIGURE_DEPENDS ${AX12_MUJOCO_LIBRARY})
message(STATUS "MuJoCo: ${AX12_MUJOCO_LIBRARY}")
