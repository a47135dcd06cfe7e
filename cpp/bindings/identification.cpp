// Bindings of the ARX-OE identification (arx.hpp, output_error.hpp, arx_oe.hpp).
#include <pybind11/eigen.h>
#include <pybind11/stl.h>

#include "bindings.hpp"
#include "mpmpp/arx_oe.hpp"
#include "mpmpp/error.hpp"

namespace py = pybind11;

namespace mpmpp::bindings {

namespace {
using ConstVec = Eigen::Ref<const Eigen::VectorXd>;
using ConstMat = Eigen::Ref<const Eigen::MatrixXd>;

Detrend parse_detrend(const std::string& s) {
  if (s == "none") return Detrend::None;
  if (s == "mean") return Detrend::Mean;
  if (s == "linear") return Detrend::Linear;
  throw InputError("detrend must be 'none', 'mean' or 'linear', got '" + s + "'");
}

OeOptions make_oe_options(int max_iterations, double max_pole_radius, int init_fir_length) {
  OeOptions o;
  o.max_iterations = max_iterations;
  o.max_pole_radius = max_pole_radius;
  o.init_fir_length = init_fir_length;
  return o;
}
}  // namespace

void bind_identification(py::module_& m) {
  py::class_<ArxResult>(m, "ArxResult",
                        "High-order ARX estimate A(q) y = sum_j q^-d_j B_j(q) u_j + e")
      .def_readonly("a", &ArxResult::a, "[1, a_1, ..., a_na]")
      .def_readonly("b", &ArxResult::b, "per input [b_j0, ..., b_j,nb_j-1]")
      .def_readonly("theta", &ArxResult::theta)
      .def_readonly("covariance", &ArxResult::covariance)
      .def_readonly("noise_variance", &ArxResult::noise_variance)
      .def_readonly("equations", &ArxResult::equations)
      .def_readonly("regularised", &ArxResult::regularised);

  py::class_<OeChannel>(m, "OeChannel",
                        "G_j = q^-delay B(q)/F(q) with nb numerator, nf denominator coefficients")
      .def(py::init([](int nb, int nf, int delay) {
             return OeChannel{nb, nf, delay};
           }),
           py::arg("nb"), py::arg("nf"), py::arg("delay"))
      .def_static("foptd", &OeChannel::foptd, py::arg("delay"))
      .def_static("fir", &OeChannel::fir, py::arg("length"), py::arg("delay"))
      .def_readonly("nb", &OeChannel::nb)
      .def_readonly("nf", &OeChannel::nf)
      .def_readonly("delay", &OeChannel::delay)
      .def("__repr__", [](const OeChannel& c) {
        return "OeChannel(nb=" + std::to_string(c.nb) + ", nf=" + std::to_string(c.nf) +
               ", delay=" + std::to_string(c.delay) + ")";
      });

  py::class_<OeResult>(m, "OeResult", "Output-error estimate, all channels of one output")
      .def_readonly("b", &OeResult::b)
      .def_readonly("f", &OeResult::f, "per channel [1, f_1, ..., f_nf]")
      .def_readonly("theta", &OeResult::theta)
      .def_readonly("covariance", &OeResult::covariance)
      .def_readonly("noise_variance", &OeResult::noise_variance)
      .def_readonly("cost", &OeResult::cost)
      .def_readonly("equations", &OeResult::equations)
      .def_readonly("iterations", &OeResult::iterations)
      .def_readonly("converged", &OeResult::converged);

  py::class_<ChannelEstimate>(m, "ChannelEstimate")
      .def_readonly("b", &ChannelEstimate::b)
      .def_readonly("f", &ChannelEstimate::f)
      .def_readonly("delay", &ChannelEstimate::delay)
      .def_readonly("fir", &ChannelEstimate::fir)
      .def_readonly("gain", &ChannelEstimate::gain)
      .def("transfer_function", &ChannelEstimate::transfer_function);

  py::class_<ArxOeResult>(m, "ArxOeResult")
      .def_readonly("channels", &ArxOeResult::channels)
      .def_readonly("noise", &ArxOeResult::noise, "a_1 .. a_na of A(q) = 1/H(q)")
      .def_readonly("arx", &ArxOeResult::arx)
      .def_readonly("oe", &ArxOeResult::oe)
      .def_readonly(
          "two_step_covariance", &ArxOeResult::two_step_covariance,
          "covariance of oe.theta with the ARX step's A(q) uncertainty (empty unless asked for)");

  py::class_<WindowEstimate>(m, "WindowEstimate")
      .def_readonly("start", &WindowEstimate::start)
      .def_readonly("ok", &WindowEstimate::ok)
      .def_readonly("message", &WindowEstimate::message)
      .def_readonly("result", &WindowEstimate::result);

  m.def(
      "arx",
      [](const ConstVec& y, const ConstMat& u, int na, std::vector<int> nb, std::vector<int> delays,
         double delta, double rank_tolerance, const std::vector<Eigen::Index>& stretch_starts) {
        return arx(y, u, ArxOrders{na, std::move(nb), std::move(delays)},
                   ArxOptions{delta, rank_tolerance}, stretch_starts);
      },
      py::arg("y"), py::arg("u"), py::arg("na"), py::arg("nb"), py::arg("delays"),
      py::arg("delta") = ArxOptions{}.delta,
      py::arg("rank_tolerance") = ArxOptions{}.rank_tolerance,
      py::arg("stretch_starts") = std::vector<Eigen::Index>{},
      py::call_guard<py::gil_scoped_release>());

  m.def(
      "oe",
      [](const ConstVec& y, const ConstMat& u, const std::vector<OeChannel>& channels,
         Eigen::Index skip, int max_iterations, double max_pole_radius, int init_fir_length,
         const std::vector<Eigen::Index>& stretch_starts) {
        return oe(y, u, channels, skip,
                  make_oe_options(max_iterations, max_pole_radius, init_fir_length),
                  stretch_starts);
      },
      py::arg("y"), py::arg("u"), py::arg("channels"), py::arg("skip") = 0,
      py::arg("max_iterations") = OeOptions{}.max_iterations,
      py::arg("max_pole_radius") = OeOptions{}.max_pole_radius,
      py::arg("init_fir_length") = OeOptions{}.init_fir_length,
      py::arg("stretch_starts") = std::vector<Eigen::Index>{},
      py::call_guard<py::gil_scoped_release>());

  py::class_<ArxOeEstimator>(m, "ArxOeEstimator",
                             "Per-window ARX-OE of one output (reusable workspace)")
      .def(py::init([](int na, std::vector<int> arx_nb, std::vector<int> delays,
                       std::vector<OeChannel> structures, std::vector<int> fir_length,
                       const std::string& detrend, double delta, int max_iterations,
                       double max_pole_radius, bool two_step_covariance) {
             ArxOeConfig c;
             c.arx = ArxOrders{na, std::move(arx_nb), std::move(delays)};
             c.structures = std::move(structures);
             c.fir_length = std::move(fir_length);
             c.detrend = parse_detrend(detrend);
             c.arx_options.delta = delta;
             c.oe_options = make_oe_options(max_iterations, max_pole_radius, 0);
             c.two_step_covariance = two_step_covariance;
             return ArxOeEstimator(std::move(c));
           }),
           py::arg("na"), py::arg("arx_nb"), py::arg("delays"), py::arg("structures"),
           py::arg("fir_length"), py::arg("detrend") = "mean",
           py::arg("delta") = ArxOptions{}.delta,
           py::arg("max_iterations") = OeOptions{}.max_iterations,
           py::arg("max_pole_radius") = OeOptions{}.max_pole_radius,
           py::arg("two_step_covariance") = false)
      .def("estimate",
           py::overload_cast<const ConstVec&, const ConstMat&, const std::vector<Eigen::Index>&>(
               &ArxOeEstimator::estimate),
           py::arg("y"), py::arg("u"), py::arg("stretch_starts") = std::vector<Eigen::Index>{},
           py::call_guard<py::gil_scoped_release>())
      .def("estimate_windows", &ArxOeEstimator::estimate_windows, py::arg("y"), py::arg("u"),
           py::arg("window"), py::arg("step"), py::call_guard<py::gil_scoped_release>());

  m.def("fir_length_to_one_percent", &fir_length_to_one_percent, py::arg("nominal"));
  m.def("without_integrators", &without_integrators, py::arg("g"));
}

}  // namespace mpmpp::bindings
