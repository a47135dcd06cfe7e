#pragma once
// A small SISO loop and detector config for C++ tests that need a detector quickly: first order
// plus 3 samples of delay, sampled every 5 s; 10 min windows every 5 min, low ARX orders,
// 6 FIR coefficients.
#include "mpmpp/detector_config.hpp"
#include "mpmpp/model_io.hpp"

namespace mpmpp::test_loops {

inline Model small_siso_model() {
  Eigen::VectorXd b(1), a(2), hn(2), hd(2);
  b << 0.1003;
  a << 1.0, -0.9048;
  hn << 1.0, -0.3;
  hd << 1.0, 0.6;
  return make_model("siso", 5.0, {"u"}, {"y"}, {{"y", {{"u", TransferFunction(b, a, 3)}}}},
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

}  // namespace mpmpp::test_loops
