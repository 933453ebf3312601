# readme_program_compiled.extern_templates (tests/CMakeLists.txt): the object files of a translation unit
# compiled in the compiled mode (AAF_EXTERN_TEMPLATES, from aaf::compiled) must not define the stages that
# aaf::compiled holds; they only refer to them. A definition means an `extern template` declaration no
# longer matches what the code instantiates (a changed signature, a new guides type) and the compile-time
# saving is silently gone.
#
#   cmake -DAAF_NM=<nm> -DAAF_OBJECTS=<object files ;-separated> -P check_extern_templates.cmake
if(NOT AAF_NM OR NOT AAF_OBJECTS)
    message(FATAL_ERROR "usage: cmake -DAAF_NM=<nm> -DAAF_OBJECTS=<objects> -P check_extern_templates.cmake")
endif()
# Mangled names of the templates that aaf::compiled instantiates (config.hpp, AAF_EXTERN_TEMPLATES).
set(held render_frame_stages filter_visibility_impl filter_pass spread_slopes_impl surface_footprint_impl prepare_pixel)
set(found_reference FALSE)
foreach(object IN LISTS AAF_OBJECTS)
    execute_process(COMMAND "${AAF_NM}" "${object}" OUTPUT_VARIABLE symbols RESULT_VARIABLE rc)
    if(NOT rc EQUAL 0)
        message(FATAL_ERROR "${AAF_NM} ${object} failed (${rc})")
    endif()
    string(REPLACE "\n" ";" lines "${symbols}")
    foreach(line IN LISTS lines)
        foreach(name IN LISTS held)
            if(line MATCHES "${name}")
                if(line MATCHES "^ +U ")
                    set(found_reference TRUE)
                else()
                    message(FATAL_ERROR "${object} defines ${line}: aaf::compiled holds it, so the TU should only "
                                        "refer to it (check the AAF_DETAIL_*_INSTANTIATIONS lists in the headers)")
                endif()
            endif()
        endforeach()
    endforeach()
endforeach()
if(NOT found_reference)
    message(FATAL_ERROR "no reference to aaf::compiled's stages in ${AAF_OBJECTS}: is it still the README program?")
endif()
message(STATUS "the compiled-mode objects define none of aaf::compiled's stages and refer to them")
