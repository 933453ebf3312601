// Minimal downstream program: includes the umbrella header and prints the library version.
#include <aaf/aaf.hpp>

#include <cstdio>

int main() {
    std::printf("aaf %s\n", aaf::version_string);
    return 0;
}
