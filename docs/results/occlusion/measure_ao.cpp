// Ad-hoc measurement of the AO filter variants (docs/results/occlusion/filter_variants.md), until aaf-tradeoff
// runs the occlusion registry family. Build from the worktree root after `cmake --build build/release`:
//   g++ -std=c++20 -O3 -march=native -Iinclude -Iexamples docs/results/occlusion/measure_ao.cpp \
//       build/release/examples/common/libaaf_examples_common.a -lassimp -lpthread -o /tmp/measure_ao
//   /tmp/measure_ao boxes; /tmp/measure_ao tentacles; /tmp/measure_ao lattice; /tmp/measure_ao scenes/bunny.json
#include <cstdio>
#include <aaf/occlusion.hpp>
#include "common/bvh.hpp"
#include "common/occlusion_methods.hpp"
#include "common/render_support.hpp"
#include "common/scene.hpp"
using namespace aaf_examples;
int main(int argc, char** argv) {
  std::string name = argc > 1 ? argv[1] : "boxes";
  scene s = name == "boxes" || name == "lattice" || name == "tentacles" ? builtin_scene(name) : load_scene_file(argv[1]);
  s.width = 160, s.height = 120;
  const bvh tracer(s.vertices, s.triangles);
  aaf::thread_pool pool(2);
  const gbuffer_images g = render_gbuffer(s, tracer, pool);
  const render_inputs in{s, tracer, g, pool, 3};
  const method_family f = occlusion_methods();
  const aaf::image<float> ref = f.references[0].render(in, 4096, 77);
  const auto mask = g.surface_mask();
  const double surf = double(g.surfaces);
  for (double spp : {8., 16., 32., 64., 128., 256.}) {
    auto out = f.methods[0].render(in, spp);
    std::printf("%s mc_ao_cosine spp %g rays/px %.1f rmse %.5f\n", name.c_str(), spp, out.rays / surf, rmse(out.image, ref, mask));
  }
  using gv = aaf::gbuffer<float, aaf::const_image_view<std::uint32_t>>;
  const gv gb{g.positions.cview(), g.normals.cview(), g.pixel_size.cview(), g.ids.cview()};
  for (auto space : {aaf::offset_space::tangent_plane, aaf::offset_space::image})
  for (float cimp : {0.1f, 0.25f, 0.5f})
  for (float mu : {1.f, 2.f, 3.f}) {
    aaf::ao_frame_settings<float> st; st.sampling.max_distance = ao_max_distance(s); st.sampling.frame_seed = 3;
    st.filter.mu = mu; st.filter.space = space; st.filter.importance_scale = cimp;
    aaf::image<float> vis(s.width, s.height);
    auto t0 = clock_type::now();
    auto rays = aaf::render_ambient_occlusion(gb, tracer, st, aaf::ao_outputs<float>{vis.view(), {}, {}, {}}, {}, pool);
    double ms = ms_since(t0);
    aaf::image<float> disp(s.width, s.height);
    for (std::size_t y = 0; y < s.height; ++y) for (std::size_t x = 0; x < s.width; ++x) disp(x,y) = !std::isfinite(g.positions(x,y).x) || !std::isfinite(vis(x,y)) ? 1.f : vis(x,y);
    std::printf("%s aaf_ao space %s c_imp %.2f mu %g rays/px %.1f rmse %.5f ms %.0f\n", name.c_str(), space == aaf::offset_space::image ? "image" : "tangent", cimp, mu, rays / surf, rmse(disp, ref, mask), ms);
  }
}
