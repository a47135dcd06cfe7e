// Load a model file, print its first channel, and filter a step through it.
#include <cmath>
#include <iostream>
#include <mpmpp/model_io.hpp>

int main(int argc, char** argv) {
  const std::string path = argc > 1 ? argv[1] : "examples/siso_gain_change/model.json";
  try {
    const mpmpp::Model model = mpmpp::load_model(path);
    const mpmpp::TransferFunction& g = *model.process[0][0];  // outputs[0] <- inputs[0]
    std::cout << model.outputs[0] << " <- " << model.inputs[0] << ": " << mpmpp::to_string(g)
              << ", dc gain " << g.dc_gain() << "\n";

    const Eigen::VectorXd y = g.filter(Eigen::VectorXd::Ones(2000));  // unit step in
    std::cout << "step response: y[" << g.delay() << "] = " << y[g.delay()]
              << ", y[1999] = " << y[1999] << "\n";
    return std::abs(y[1999] - g.dc_gain()) < 1e-9 ? 0 : 1;  // a stable channel settles at G(1)
  } catch (const mpmpp::InputError& e) {  // one line naming the file and the field
    std::cerr << e.what() << "\n";
    return 2;
  }
}
