// aaf — axis-aligned filtering of ray-traced soft shadows (Mehta, Wang, Ramamoorthi 2012).
// SPDX-License-Identifier: MIT
#pragma once

/// Version of the library, also encoded in the inline namespace (`aaf::v0`).
#define AAF_VERSION_MAJOR 0
#define AAF_VERSION_MINOR 1
#define AAF_VERSION_PATCH 0
#define AAF_VERSION_STRING "0.1.0"

namespace aaf {
inline namespace v0 {

/// Library version as a string ("major.minor.patch"), for logs and `--version` output.
inline constexpr const char* version_string = AAF_VERSION_STRING;

}  // namespace v0
}  // namespace aaf
