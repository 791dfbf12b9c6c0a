# haptic_warnings: the warnings every target of the project compiles with, C
# (common/, firmware/) and C++ (calib/) alike. Each target links it PRIVATE, so
# the flags belong to the target and reach nothing that links it;
# HAPTIC_WERROR (the test command) makes them errors.
add_library(haptic_warnings INTERFACE)
target_compile_options(haptic_warnings INTERFACE -Wall -Wextra -Wpedantic $<$<BOOL:${HAPTIC_WERROR}>:-Werror>)

# haptic_check_warnings(<dir>): stops the configuration if a target that
# compiles sources, in <dir> or below, does not link haptic_warnings.
function(haptic_check_warnings dir)
  get_property(targets DIRECTORY ${dir} PROPERTY BUILDSYSTEM_TARGETS)
  foreach(t IN LISTS targets)
    get_target_property(type ${t} TYPE)
    if(type MATCHES "^(EXECUTABLE|STATIC_LIBRARY|SHARED_LIBRARY|MODULE_LIBRARY|OBJECT_LIBRARY)$")
      get_target_property(links ${t} LINK_LIBRARIES)
      if(NOT "haptic_warnings" IN_LIST links)
        message(FATAL_ERROR "target ${t} (${dir}) does not link haptic_warnings: "
                            "add it with target_link_libraries(${t} PRIVATE haptic_warnings)")
      endif()
    endif()
  endforeach()
  get_property(subdirs DIRECTORY ${dir} PROPERTY SUBDIRECTORIES)
  foreach(d IN LISTS subdirs)
    haptic_check_warnings(${d})
  endforeach()
endfunction()
