#pragma once
// A small SISO loop and detector config for C++ tests that need a detector quickly: first order
// plus 3 samples of delay, sampled every 5 s; 10 min windows every 5 min, low ARX orders,
// 6 FIR coefficients.
#include <cstdint>
#include <random>

#include "mpmpp/detector_config.hpp"
#include "mpmpp/model_io.hpp"

namespace mpmpp::test_loops {

// The paper's SISO MD loop at 5 s, with the given dead time in samples.
inline Model small_siso_model(int delay = 3) {
  Eigen::VectorXd b(1), a(2), hn(2), hd(2);
  b << 0.1003;
  a << 1.0, -0.9048;
  hn << 1.0, -0.3;
  hd << 1.0, 0.6;
  return make_model("siso", 5.0, {"u"}, {"y"}, {{"y", {{"u", TransferFunction(b, a, delay)}}}},
                    {{"y", TransferFunction(hn, hd)}});
}

inline DetectorConfig short_window_config(double inspection_s) {
  DetectorConfig c = DetectorConfig::paper_siso();
  c.window_s = 600;
  c.step_s = 300;
  c.inspection_s = inspection_s;
  c.arx_order_a = 3;
  c.arx_order_b = 3;
  c.fir_length = 6;
  c.oe_structure = OeStructure::Fir;
  return c;
}

struct LoopSamples {
  Eigen::VectorXd t;
  Eigen::MatrixXd u, y;
};

// Open-loop data of a SISO model: a random step in u every 13 samples through the model, white
// noise (sd 0.05) through its noise model; time from t0 in steps of the model's 5 s.
inline LoopSamples random_step_samples(const Model& m, Eigen::Index n, std::uint64_t seed,
                                       double t0 = 0.0) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> e(0.0, 0.05);
  std::uniform_real_distribution<double> level(-1.0, 1.0);
  LoopSamples s{Eigen::VectorXd(n), Eigen::MatrixXd(n, 1), Eigen::MatrixXd(n, 1)};
  double v = 0;
  for (Eigen::Index k = 0; k < n; ++k) {
    if (k % 13 == 0) v = level(rng);
    s.u(k, 0) = v;
    s.t[k] = t0 + 5.0 * static_cast<double>(k);
  }
  const Eigen::VectorXd white = Eigen::VectorXd::NullaryExpr(n, [&] { return e(rng); });
  s.y.col(0) = m.process[0][0]->filter(s.u.col(0)) + m.noise[0].filter(white);
  return s;
}

}  // namespace mpmpp::test_loops
