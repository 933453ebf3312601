# Test driver for the consumer.* ctest tests (registered in tests/CMakeLists.txt).
#
#   cmake -DAAF_MODE=<install|find_package|pkg_config|add_subdirectory>
#         -DAAF_SOURCE_DIR=... -DAAF_BUILD_DIR=... -DAAF_CONFIG=... -DAAF_CONSUMER_DIR=...
#         -DAAF_WORK_DIR=... -DAAF_EXPECTED_VERSION=... -DAAF_PKGCONFIG_DIR=...
#         -DAAF_CXX_COMPILER=... -DAAF_GENERATOR=... [-DAAF_MAKE_PROGRAM=...] [-DAAF_PKG_CONFIG=...]
#         -P run_consumer_test.cmake
#
# install          cmake --install <AAF_BUILD_DIR> --prefix <AAF_WORK_DIR>/prefix (fixture setup)
# find_package     configure/build/run tests/consumer with CMAKE_PREFIX_PATH=<prefix>
# pkg_config       compile tests/consumer/main.cpp with `pkg-config --cflags --libs aaf`, run it
# add_subdirectory configure/build/run tests/consumer with AAF_SOURCE_DIR=<aaf source tree>

cmake_minimum_required(VERSION 3.25)

foreach(var AAF_MODE AAF_SOURCE_DIR AAF_BUILD_DIR AAF_CONSUMER_DIR AAF_WORK_DIR
            AAF_EXPECTED_VERSION AAF_CXX_COMPILER AAF_GENERATOR)
    if(NOT DEFINED ${var} OR "${${var}}" STREQUAL "")
        message(FATAL_ERROR "run_consumer_test.cmake: ${var} is not set")
    endif()
endforeach()

set(prefix "${AAF_WORK_DIR}/prefix")

# run(<command>...): echo, execute, print output, abort the test on a non-zero exit code.
function(run)
    string(JOIN " " pretty ${ARGN})
    message(STATUS "$ ${pretty}")
    execute_process(COMMAND ${ARGN}
        RESULT_VARIABLE rc
        OUTPUT_VARIABLE out
        ERROR_VARIABLE out)
    if(out)
        message("${out}")
    endif()
    if(NOT rc EQUAL 0)
        message(FATAL_ERROR "command failed (${rc}): ${pretty}")
    endif()
    set(last_output "${out}" PARENT_SCOPE)
endfunction()

# run_and_check_version(<executable>): run the consumer and check what it prints.
function(run_and_check_version exe)
    run("${exe}")
    string(STRIP "${last_output}" printed)
    if(NOT printed STREQUAL "aaf ${AAF_EXPECTED_VERSION}")
        message(FATAL_ERROR "consumer printed '${printed}', expected 'aaf ${AAF_EXPECTED_VERSION}'")
    endif()
endfunction()

# build_consumer(<work-subdir> <extra cmake args>...): fresh configure + build + run.
function(build_consumer subdir)
    set(bin "${AAF_WORK_DIR}/${subdir}")
    file(REMOVE_RECURSE "${bin}")
    set(generator_args -G "${AAF_GENERATOR}")
    if(AAF_MAKE_PROGRAM)
        list(APPEND generator_args "-DCMAKE_MAKE_PROGRAM=${AAF_MAKE_PROGRAM}")
    endif()
    run("${CMAKE_COMMAND}" -S "${AAF_CONSUMER_DIR}" -B "${bin}" ${generator_args}
        "-DCMAKE_CXX_COMPILER=${AAF_CXX_COMPILER}"
        -DCMAKE_BUILD_TYPE=Release
        -DCMAKE_FIND_PACKAGE_NO_PACKAGE_REGISTRY=ON
        ${ARGN})
    set(config_args "")
    if(AAF_CONFIG)
        set(config_args --config Release)
    endif()
    run("${CMAKE_COMMAND}" --build "${bin}" ${config_args})
    set(exe "${bin}/aaf_consumer")
    if(NOT EXISTS "${exe}" AND EXISTS "${bin}/Release/aaf_consumer")
        set(exe "${bin}/Release/aaf_consumer")  # multi-config generators
    endif()
    run_and_check_version("${exe}")
endfunction()

if(AAF_MODE STREQUAL "install")
    file(REMOVE_RECURSE "${prefix}")
    set(config_args "")
    if(AAF_CONFIG)
        set(config_args --config "${AAF_CONFIG}")
    endif()
    run("${CMAKE_COMMAND}" --install "${AAF_BUILD_DIR}" --prefix "${prefix}" ${config_args})
    foreach(file
            "include/aaf/aaf.hpp"
            "include/aaf/version.hpp"
            "${AAF_PKGCONFIG_DIR}/aaf.pc")
        if(NOT EXISTS "${prefix}/${file}")
            message(FATAL_ERROR "install did not produce ${prefix}/${file}")
        endif()
    endforeach()
    file(GLOB_RECURSE config_files "${prefix}/*/aafConfig.cmake" "${prefix}/*/aafConfigVersion.cmake")
    list(LENGTH config_files n)
    if(NOT n EQUAL 2)
        message(FATAL_ERROR "expected aafConfig.cmake and aafConfigVersion.cmake under ${prefix}, found: ${config_files}")
    endif()

elseif(AAF_MODE STREQUAL "find_package")
    if(NOT EXISTS "${prefix}")
        message(FATAL_ERROR "${prefix} does not exist: run the consumer.install test first")
    endif()
    build_consumer(find_package
        "-DCMAKE_PREFIX_PATH=${prefix}"
        "-DAAF_EXPECTED_PREFIX=${prefix}")

elseif(AAF_MODE STREQUAL "add_subdirectory")
    build_consumer(add_subdirectory "-DAAF_SOURCE_DIR=${AAF_SOURCE_DIR}")

elseif(AAF_MODE STREQUAL "pkg_config")
    if(NOT AAF_PKG_CONFIG)
        message(FATAL_ERROR "AAF_PKG_CONFIG (path to pkg-config) is not set")
    endif()
    if(NOT EXISTS "${prefix}/${AAF_PKGCONFIG_DIR}/aaf.pc")
        message(FATAL_ERROR "${prefix}/${AAF_PKGCONFIG_DIR}/aaf.pc does not exist: run the consumer.install test first")
    endif()
    if(DEFINED ENV{PKG_CONFIG_PATH} AND NOT "$ENV{PKG_CONFIG_PATH}" STREQUAL "")
        set(ENV{PKG_CONFIG_PATH} "${prefix}/${AAF_PKGCONFIG_DIR}:$ENV{PKG_CONFIG_PATH}")
    else()
        set(ENV{PKG_CONFIG_PATH} "${prefix}/${AAF_PKGCONFIG_DIR}")
    endif()

    run("${AAF_PKG_CONFIG}" --modversion aaf)
    string(STRIP "${last_output}" pc_version)
    if(NOT pc_version STREQUAL AAF_EXPECTED_VERSION)
        message(FATAL_ERROR "pkg-config reports aaf ${pc_version}, expected ${AAF_EXPECTED_VERSION}")
    endif()

    run("${AAF_PKG_CONFIG}" --cflags aaf)
    string(STRIP "${last_output}" cflags)
    string(FIND " ${cflags} " " -I${prefix}/include " pos)
    if(pos EQUAL -1)
        message(FATAL_ERROR "`pkg-config --cflags aaf` is '${cflags}', expected it to contain -I${prefix}/include")
    endif()
    run("${AAF_PKG_CONFIG}" --libs aaf)
    string(STRIP "${last_output}" libs)

    separate_arguments(cflags_list UNIX_COMMAND "${cflags}")
    separate_arguments(libs_list UNIX_COMMAND "${libs}")
    set(bin "${AAF_WORK_DIR}/pkg_config")
    file(REMOVE_RECURSE "${bin}")
    file(MAKE_DIRECTORY "${bin}")
    run("${AAF_CXX_COMPILER}" -std=c++20 -Wall -Wextra -Wpedantic -Werror ${cflags_list}
        "${AAF_CONSUMER_DIR}/main.cpp" -o "${bin}/aaf_consumer" ${libs_list})
    run_and_check_version("${bin}/aaf_consumer")

else()
    message(FATAL_ERROR "unknown AAF_MODE '${AAF_MODE}'")
endif()
