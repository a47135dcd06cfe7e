#pragma once
// The nominal MIMO model a controller uses (FORMATS.md "Model file"):
// process[i][j] is the channel output i <- input j (absent = exactly zero, the
// model claims no coupling); noise[i] is the disturbance model H_i of output i
// (monic, stable, inversely stable; H = 1 when the file gives none).
#include <optional>
#include <string>
#include <vector>

#include "mpmpp/transfer_function.hpp"

namespace mpmpp {

struct Model {
  std::string name;
  double sample_time_s = 1.0;
  std::vector<std::string> inputs;
  std::vector<std::string> outputs;
  std::vector<std::vector<std::optional<TransferFunction>>> process;  // [output][input]
  std::vector<TransferFunction> noise;                                 // [output]

  int num_inputs() const { return static_cast<int>(inputs.size()); }
  int num_outputs() const { return static_cast<int>(outputs.size()); }
  bool has_channel(int i, int j) const { return process[i][j].has_value(); }
};

}  // namespace mpmpp
