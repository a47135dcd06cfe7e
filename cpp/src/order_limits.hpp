#pragma once

namespace mpmpp::detail {

// Largest delay or order (samples, coefficients) accepted at the engine's boundary: far
// beyond any plant (the model file allows delays up to the same 1,000,000 samples), small
// enough that sums of a few stay in int and workspaces stay small. A hostile 2^31 - 1 would
// otherwise overflow index arithmetic (a segfault in the ARX regressors) or ask for gigabytes.
inline constexpr int kMaxLag = 1000000;

}  // namespace mpmpp::detail
