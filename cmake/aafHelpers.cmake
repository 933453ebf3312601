# Helper functions shared by the project's own targets (tests, benchmarks, examples).
# None of these are applied to the `aaf` interface target: consumers get exactly the
# usage requirements they ask for (C++20, include dirs, GLM, Threads) and nothing else.

include_guard(GLOBAL)

# aaf_set_warnings(<target>)
#   Strict warnings as errors for code this project compiles itself. The set is chosen for
#   float-heavy graphics code: -Wconversion/-Wsign-conversion are deliberately left out (they
#   flag every int->float pixel coordinate), everything else that catches real bugs is on.
function(aaf_set_warnings target)
    if(CMAKE_CXX_COMPILER_ID MATCHES "GNU|Clang")
        target_compile_options(${target} PRIVATE
            -Wall
            -Wextra
            -Wpedantic
            -Wshadow
            -Wnon-virtual-dtor
            -Wold-style-cast
            -Wcast-align
            -Woverloaded-virtual
            -Wnull-dereference
            -Wdouble-promotion
            -Werror)
    elseif(MSVC)
        target_compile_options(${target} PRIVATE /W4 /WX /permissive-)
    endif()
endfunction()

# aaf_native_flags(<out-var>)
#   The extra optimisation flags benchmarks and examples get when AAF_NATIVE is ON
#   (empty list otherwise, or for compilers that do not understand them).
function(aaf_native_flags out_var)
    set(flags "")
    if(AAF_NATIVE AND CMAKE_CXX_COMPILER_ID MATCHES "GNU|Clang")
        set(flags -O3 -march=native)
    endif()
    set(${out_var} "${flags}" PARENT_SCOPE)
endfunction()

# aaf_set_native(<target>)
#   Apply aaf_native_flags() to <target>. Only ever used on benchmark and example
#   executables; never on the interface library, so consumers are not forced onto
#   the build machine's instruction set.
function(aaf_set_native target)
    aaf_native_flags(flags)
    if(flags)
        target_compile_options(${target} PRIVATE ${flags})
    endif()
endfunction()

# aaf_build_flags_string(<target> <out-var>)
#   A human-readable description of how <target> is compiled (compiler, build type, flags),
#   suitable for a compile definition so a benchmark can print what it was built with.
function(aaf_build_flags_string target out_var)
    set(config "${CMAKE_BUILD_TYPE}")
    if(NOT config)
        set(config "<none>")
    endif()
    string(TOUPPER "${config}" config_upper)
    aaf_native_flags(native)
    string(JOIN " " native_str ${native})
    set(parts
        "${CMAKE_CXX_COMPILER_ID} ${CMAKE_CXX_COMPILER_VERSION}"
        "${config}:"
        "${CMAKE_CXX_FLAGS}"
        "${CMAKE_CXX_FLAGS_${config_upper}}"
        "${native_str}")
    string(JOIN " " str ${parts})
    string(REGEX REPLACE "[ \t]+" " " str "${str}")
    string(STRIP "${str}" str)
    # Keep the string safe to embed in a C++ string literal.
    string(REPLACE "\\" "/" str "${str}")
    string(REPLACE "\"" "'" str "${str}")
    set(${out_var} "${str}" PARENT_SCOPE)
endfunction()
