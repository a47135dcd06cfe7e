#pragma once
// The nominal MIMO model a controller uses (docs/formats.md "Model file"):
// process[i][j] is the channel output i <- input j (absent = exactly zero, the
// model claims no coupling); noise[i] is the disturbance model H_i of output i
// (monic, stable, inversely stable; H = 1 when the file gives none); actuators[j] is the
// valve model of input j (absent = a linear valve: the channels see the input itself).
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "mpmpp/transfer_function.hpp"

namespace mpmpp {

// The model file's description of a nonlinear actuator between input j and the process
// (docs/stiction.md "Model file"): the channels from input j are driven by the valve position
// f(u_j). `kind` is one of
// stick_slip (S, J), he (fs, fd), backlash (S), deadband (width),
// saturation (lower, upper); parameters in input units. `confidence` (0..1, optional, < 0
// when absent) is how sure the diagnosis that found it was.
struct ActuatorSpec {
  std::string kind;
  std::map<std::string, double> parameters;
  double confidence = -1.0;

  bool operator==(const ActuatorSpec& o) const {
    return kind == o.kind && parameters == o.parameters && confidence == o.confidence;
  }
};

struct Model {
  std::string name;
  double sample_time_s = 1.0;
  std::vector<std::string> inputs;
  std::vector<std::string> outputs;
  std::vector<std::vector<std::optional<TransferFunction>>> process;  // [output][input]
  std::vector<TransferFunction> noise;                                // [output]
  std::vector<std::optional<ActuatorSpec>> actuators;                 // [input]

  int num_inputs() const { return static_cast<int>(inputs.size()); }
  int num_outputs() const { return static_cast<int>(outputs.size()); }
  bool has_channel(int i, int j) const { return process[i][j].has_value(); }
  // A channel written as zero (gain 0) says what an absent one says; the detector takes it
  // as absent (its impulse response sizes no FIR, its directions span nothing).
  bool acts(int i, int j) const { return has_channel(i, j) && !process[i][j]->is_zero(); }
  bool has_actuators() const {
    for (const auto& a : actuators)
      if (a) return true;
    return false;
  }
};

}  // namespace mpmpp
