# The ROS 2 wheels' exported targets name the include folders of the machine that built them
# (/opt/python/...): point them at this Python's and numpy's, or CMake refuses to generate.
get_directory_property(_imported IMPORTED_TARGETS)
foreach(_target ${_imported})
  get_target_property(_dirs ${_target} INTERFACE_INCLUDE_DIRECTORIES)
  if(_dirs MATCHES "/opt/python/")
    list(FILTER _dirs EXCLUDE REGEX "^/opt/python/")
    list(APPEND _dirs ${Python3_INCLUDE_DIRS} ${Python3_NumPy_INCLUDE_DIRS})
    set_target_properties(${_target} PROPERTIES INTERFACE_INCLUDE_DIRECTORIES "${_dirs}")
  endif()
endforeach()
