// SPDX-License-Identifier: MIT
// aaf::compiled, the optional compiled mode (README "Compiled mode"): the explicit instantiations, for double,
// of everything render_frame, filter_visibility, spread_slopes and surface_footprint do without the
// tracer. Translation units that link aaf::compiled get AAF_EXTERN_TEMPLATES and compile only the
// gathering over their own tracer. The lists are the headers' own (AAF_DETAIL_*_INSTANTIATIONS).
#include <aaf/aaf.hpp>

namespace aaf {
inline namespace v0 {

AAF_DETAIL_GATHER_INSTANTIATIONS(, double)
AAF_DETAIL_FOOTPRINT_INSTANTIATIONS(, double)
AAF_DETAIL_FILTER_INSTANTIATIONS(, double)
AAF_DETAIL_PIPELINE_INSTANTIATIONS(, double)

}  // namespace v0
}  // namespace aaf
