# Shared by rfidnav_msgs and the vendored interface packages (vendor/): find the message packages an interface
# package depends on and repair their Python targets.
#
# The ROS 2 Jazzy wheels on PyPI export the wheel builder's Python include directories
# (/opt/python/cp311-cp311/...) from each <pkg>__rosidl_generator_py target, and CMake rejects
# an imported target naming a missing directory. Keep the directories that exist and add this
# interpreter's and numpy's headers. On a regular Jazzy install every directory exists and the
# lists come out unchanged but for two already-present paths.
macro(repair_wheel_python_targets)
  # Found here (rosidl would find them itself) so their Python targets can be repaired below.
  foreach(package IN ITEMS ${ARGN})
    find_package(${package} REQUIRED)
  endforeach()
  find_package(Python3 REQUIRED COMPONENTS Interpreter Development NumPy)
  foreach(package IN ITEMS ${ARGN})
    set(python_target ${package}::${package}__rosidl_generator_py)
    if(TARGET ${python_target})
      get_target_property(include_dirs ${python_target} INTERFACE_INCLUDE_DIRECTORIES)
      set(existing_dirs "")
      foreach(dir IN LISTS include_dirs)
        if(EXISTS "${dir}" OR dir MATCHES "^\\$<")
          list(APPEND existing_dirs "${dir}")
        endif()
      endforeach()
      list(APPEND existing_dirs ${Python3_INCLUDE_DIRS} ${Python3_NumPy_INCLUDE_DIRS})
      list(REMOVE_DUPLICATES existing_dirs)
      set_target_properties(${python_target} PROPERTIES INTERFACE_INCLUDE_DIRECTORIES "${existing_dirs}")
    endif()
  endforeach()
endmacro()
