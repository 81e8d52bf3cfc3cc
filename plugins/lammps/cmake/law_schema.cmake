# The schema of the law's parameter file (src/geocontact/data/law-schema.json, the table the
# Python loader reads) embedded in a generated header, geocontact/law_schema.hpp, so the C++
# reader (params.hpp) validates from the same file with no path to it at run time.
# geocontact_law_schema(<include dir to create>): used by this project and the top-level one.
# Without CMake in your build: cmake -DOUT=<include dir> -P plugins/lammps/cmake/law_schema.cmake
set(GEOCONTACT_LAW_SCHEMA ${CMAKE_CURRENT_LIST_DIR}/../../../src/geocontact/data/law-schema.json)
get_filename_component(GEOCONTACT_LAW_SCHEMA ${GEOCONTACT_LAW_SCHEMA} ABSOLUTE)
set(GEOCONTACT_LAW_SCHEMA_TEMPLATE ${CMAKE_CURRENT_LIST_DIR}/law_schema.hpp.in)

function(geocontact_law_schema include_dir)
  file(READ ${GEOCONTACT_LAW_SCHEMA} GEOCONTACT_LAW_SCHEMA_JSON)
  configure_file(${GEOCONTACT_LAW_SCHEMA_TEMPLATE}
                 ${include_dir}/geocontact/law_schema.hpp @ONLY)
  if(NOT CMAKE_SCRIPT_MODE_FILE)
    # a change of the schema reconfigures, and so regenerates the header
    set_property(DIRECTORY APPEND PROPERTY CMAKE_CONFIGURE_DEPENDS ${GEOCONTACT_LAW_SCHEMA})
  endif()
endfunction()

if(CMAKE_SCRIPT_MODE_FILE AND OUT)
  geocontact_law_schema(${OUT})
endif()
