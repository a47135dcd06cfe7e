#pragma once
// Upper tail of the chi-square distribution, for the Wald tests of the detector.

namespace mpmpp {

// P(X > x) for X ~ chi-square(dof): the regularised upper incomplete gamma Q(dof / 2, x / 2),
// by its power series below a + 1 and its continued fraction (modified Lentz) above.
// 1 for x <= 0; InputError for dof < 1.
double chi_square_survival(double x, int dof);
// log P(X > x), finite where P underflows (a window far from the training, T in the
// thousands): the detector's Wald scores are log10(p / level).
double chi_square_log_survival(double x, int dof);

}  // namespace mpmpp
