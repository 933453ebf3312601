# Install-time helper (included from an install(CODE) block in the top-level CMakeLists.txt):
# writes aaf.pc with the prefix actually being installed to. Expects AAF_PC_TEMPLATE,
# AAF_PC_OUTPUT, AAF_PC_VERSION, AAF_PC_DESCRIPTION, AAF_PC_REQUIRES, AAF_PC_EXTRA_CFLAGS and
# AAF_PC_INCLUDEDIR; CMAKE_INSTALL_PREFIX is the install-time prefix (without DESTDIR).

set(AAF_PC_PREFIX "${CMAKE_INSTALL_PREFIX}")
if(IS_ABSOLUTE "${AAF_PC_INCLUDEDIR}")
    set(AAF_PC_INCLUDEDIR_FULL "${AAF_PC_INCLUDEDIR}")
else()
    set(AAF_PC_INCLUDEDIR_FULL "\${prefix}/${AAF_PC_INCLUDEDIR}")
endif()
configure_file("${AAF_PC_TEMPLATE}" "${AAF_PC_OUTPUT}" @ONLY)
