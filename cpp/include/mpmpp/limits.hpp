#pragma once
// The largest magnitude a number read from a user's file may have.

namespace mpmpp {

// A value of this magnitude or more cannot be computed with: its square summed over a record
// overflows double precision (1e100 squared is 1e200). No measurement in engineering units and
// no model coefficient comes near it; the fits met the infinities far from the cause ("SVD did
// not converge", "num has a non-finite coefficient").
constexpr double kLargestValue = 1e100;

}  // namespace mpmpp
