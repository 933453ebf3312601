# Extraction of the complete example program embedded in README.md.
#
# Marker syntax (in README.md):
#
#     <!-- readme-program -->
#     ```cpp
#     #include <aaf/aaf.hpp>
#     int main() { ... }
#     ```
#
# The first ```cpp fenced block after the first line containing `<!-- readme-program -->` is
# the program. It is compiled as the `readme_program` executable and run by ctest, so the
# README's code can never silently rot. A `#line` directive maps compiler diagnostics back to
# README.md.
#
# Two uses:
#   include(aafReadmeProgram) + aaf_readme_program_extract(...)   (configure time, CMakeLists)
#   cmake -DAAF_README=<README.md> -DAAF_OUTPUT=<file.cpp> -P aafReadmeProgram.cmake
#                                                                  (build time, custom command)

set(AAF_README_MARKER "<!-- readme-program -->")

# aaf_readme_program_extract(<readme> <out-code-var> <out-error-var>)
#   Sets <out-code-var> to the program text (prefixed by a #line directive) or to "" and
#   <out-error-var> to a description of why nothing was found.
function(aaf_readme_program_extract readme out_code out_error)
    set(${out_code} "" PARENT_SCOPE)
    if(NOT EXISTS "${readme}")
        set(${out_error} "${readme} does not exist" PARENT_SCOPE)
        return()
    endif()
    file(READ "${readme}" text)
    string(REPLACE "\r\n" "\n" text "${text}")

    string(FIND "${text}" "${AAF_README_MARKER}" marker_pos)
    if(marker_pos EQUAL -1)
        set(${out_error} "no `${AAF_README_MARKER}` marker line in ${readme}" PARENT_SCOPE)
        return()
    endif()
    # Start searching for the fence on the line after the marker.
    string(SUBSTRING "${text}" ${marker_pos} -1 rest)
    string(FIND "${rest}" "\n" eol)
    if(eol EQUAL -1)
        set(${out_error} "no ```cpp block after the marker in ${readme}" PARENT_SCOPE)
        return()
    endif()
    math(EXPR after_marker "${marker_pos} + ${eol} + 1")
    string(SUBSTRING "${text}" ${after_marker} -1 rest)

    # The opening fence must start a line: "```cpp" optionally followed by attributes.
    string(FIND "\n${rest}" "\n```cpp" fence_pos)
    if(fence_pos EQUAL -1)
        set(${out_error} "no ```cpp block after the marker in ${readme}" PARENT_SCOPE)
        return()
    endif()
    string(SUBSTRING "${rest}" ${fence_pos} -1 block)
    string(FIND "${block}" "\n" eol)
    if(eol EQUAL -1)
        set(${out_error} "unterminated ```cpp block after the marker in ${readme}" PARENT_SCOPE)
        return()
    endif()
    math(EXPR body_start "${eol} + 1")
    string(SUBSTRING "${block}" ${body_start} -1 body)

    # Closing fence: a line starting with ```.
    string(FIND "\n${body}" "\n```" close_pos)
    if(close_pos EQUAL -1)
        set(${out_error} "unterminated ```cpp block after the marker in ${readme}" PARENT_SCOPE)
        return()
    endif()
    string(SUBSTRING "${body}" 0 ${close_pos} code)
    if(code STREQUAL "")
        set(${out_error} "the ```cpp block after the marker in ${readme} is empty" PARENT_SCOPE)
        return()
    endif()

    # 1-based README line of the first code line = newlines before it + 1.
    math(EXPR code_offset "${after_marker} + ${fence_pos} + ${body_start}")
    string(SUBSTRING "${text}" 0 ${code_offset} before)
    string(REGEX REPLACE "[^\n]" "" newlines "${before}")
    string(LENGTH "${newlines}" line)
    math(EXPR line "${line} + 1")

    set(${out_code}
        "// Generated from ${readme} by cmake/aafReadmeProgram.cmake. Do not edit.\n#line ${line} \"${readme}\"\n${code}\n"
        PARENT_SCOPE)
    set(${out_error} "" PARENT_SCOPE)
endfunction()

if(CMAKE_SCRIPT_MODE_FILE AND CMAKE_SCRIPT_MODE_FILE STREQUAL CMAKE_CURRENT_LIST_FILE)
    if(NOT AAF_README OR NOT AAF_OUTPUT)
        message(FATAL_ERROR "usage: cmake -DAAF_README=<README.md> -DAAF_OUTPUT=<out.cpp> -P ${CMAKE_CURRENT_LIST_FILE}")
    endif()
    aaf_readme_program_extract("${AAF_README}" code error)
    if(code STREQUAL "")
        message(FATAL_ERROR
            "readme_program: ${error}.\n"
            "README.md must contain a line `${AAF_README_MARKER}` followed by a ```cpp block "
            "holding a complete program (re-run cmake if you removed it on purpose).")
    endif()
    file(WRITE "${AAF_OUTPUT}" "${code}")
endif()
