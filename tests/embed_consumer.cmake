# Installs a built diffreg into a fresh prefix, then configures, builds and runs the example
# consumer examples/embed against that prefix alone. Run by CTest (test embed_consumer):
#   cmake -DDIFFREG_SOURCE_DIR=... -DDIFFREG_BINARY_DIR=... -DWORK_DIR=... [-DCXX=...]
#         -P tests/embed_consumer.cmake
foreach(var DIFFREG_SOURCE_DIR DIFFREG_BINARY_DIR WORK_DIR)
  if(NOT DEFINED ${var})
    message(FATAL_ERROR "embed_consumer: -D${var}=... is required")
  endif()
endforeach()

function(run what)
  execute_process(COMMAND ${ARGN} RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "embed_consumer: ${what} failed (${rc}):\n${out}\n${err}")
  endif()
  set(run_output "${out}" PARENT_SCOPE)
endfunction()

set(prefix ${WORK_DIR}/prefix)
set(build ${WORK_DIR}/build)
file(REMOVE_RECURSE ${WORK_DIR})

run("installing into ${prefix}" ${CMAKE_COMMAND} --install ${DIFFREG_BINARY_DIR} --prefix ${prefix})

# The installed package must not point back into the source or build tree.
file(GLOB_RECURSE package_files ${prefix}/*.cmake)
if(NOT package_files)
  message(FATAL_ERROR "embed_consumer: no CMake package files under ${prefix}")
endif()
foreach(f ${package_files})
  file(READ ${f} text)
  foreach(tree ${DIFFREG_SOURCE_DIR} ${DIFFREG_BINARY_DIR})
    string(FIND "${text}" "${tree}" at)
    if(NOT at EQUAL -1)
      message(FATAL_ERROR "embed_consumer: ${f} refers to ${tree}")
    endif()
  endforeach()
endforeach()

set(configure_args -S ${DIFFREG_SOURCE_DIR}/examples/embed -B ${build}
    -DCMAKE_BUILD_TYPE=Release -DCMAKE_PREFIX_PATH=${prefix}
    -DCMAKE_FIND_USE_PACKAGE_REGISTRY=OFF)
if(DEFINED CXX)
  list(APPEND configure_args -DCMAKE_CXX_COMPILER=${CXX})
endif()
run("configuring examples/embed" ${CMAKE_COMMAND} ${configure_args})
file(STRINGS ${build}/CMakeCache.txt found REGEX "^diffreg_DIR:")
if(NOT found MATCHES "^diffreg_DIR:PATH=${prefix}/")
  message(FATAL_ERROR "embed_consumer: found diffreg elsewhere: ${found}")
endif()
run("building examples/embed" ${CMAKE_COMMAND} --build ${build})
run("running the example" ${build}/embed ${DIFFREG_SOURCE_DIR}/meshes/bar.obj
    ${DIFFREG_SOURCE_DIR}/meshes/bar-bend.json)
message(STATUS "embed_consumer: ${run_output}")
