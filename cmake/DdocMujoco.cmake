# Debian's mujocoConfig.cmake names /usr/include/libqhull_r/ as an include directory that
# libmujoco-dev does not install, so the imported target mujoco::mujoco fails to configure.
# We locate the header and library ourselves and wrap them in ddoc::mujoco_lib.
find_path(DDOC_MUJOCO_INCLUDE_DIR mujoco/mujoco.h REQUIRED)
find_library(DDOC_MUJOCO_LIBRARY NAMES mujoco REQUIRED)
if(NOT TARGET ddoc::mujoco_lib)
  add_library(ddoc::mujoco_lib INTERFACE IMPORTED)
  set_target_properties(ddoc::mujoco_lib PROPERTIES
    INTERFACE_INCLUDE_DIRECTORIES "${DDOC_MUJOCO_INCLUDE_DIR}"
    INTERFACE_LINK_LIBRARIES "${DDOC_MUJOCO_LIBRARY}")
endif()
message(STATUS "ddoc: MuJoCo ${DDOC_MUJOCO_LIBRARY}")
