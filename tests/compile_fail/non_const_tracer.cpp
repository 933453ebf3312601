// SPDX-License-Identifier: MIT
// Must NOT compile: a tracer whose query is not const. The test `tracer_diagnostic.non_const` builds this
// file and passes when the compiler's output carries check_tracer's message naming the member and the reason.
#include <aaf/pipeline.hpp>

struct my_tracer {
    float nearest_occluder(const aaf::shadow_segment<float>&) { return aaf::no_occluder<float>; }  // missing const
};

int main() {
    aaf::image<glm::vec3> p(1, 1, glm::vec3(0)), n(1, 1, glm::vec3(0, 1, 0));
    aaf::image<float> d(1, 1, 1.0f), v(1, 1);
    aaf::frame_workspace<float> ws;
    const my_tracer tracer;
    aaf::render_frame(aaf::gbuffer<float>{p.cview(), n.cview(), d.cview()}, aaf::area_light<float>{}, tracer, {v.view()}, ws);
}
