#pragma once
// The model file (docs/formats.md "Model file"): read, validate, write.
//
// Every problem is an InputError whose message is one line naming the file and
// the JSON path, e.g.
//   model.json: process.dry_weight.stock_flow: den[0] must be non-zero
// Channels given as first-order-plus-dead-time {gain, time_constant_s, dead_time_s}
// are discretised with a zero-order hold (TransferFunction::from_foptd) on load;
// written files always use the discrete form {num, den, delay}, so
// load -> save -> load gives an identical model and an identical file.
#include <map>
#include <string>
#include <vector>

#include "mpmpp/error.hpp"
#include "mpmpp/model.hpp"
#include "mpmpp/transfer_function.hpp"

namespace mpmpp {

// Channels by name, as in the file: process[output][input], noise[output].
using ProcessChannels = std::map<std::string, std::map<std::string, TransferFunction>>;
using NoiseModels = std::map<std::string, TransferFunction>;
using ActuatorSpecs = std::map<std::string, ActuatorSpec>;  // by input name

// The version of the optional "actuators" block this library reads and writes.
constexpr int kActuatorsVersion = 1;

// Builds a validated Model from named parts (what the file says, and what code
// that builds models, e.g. the simulator or `update`, says). Absent channels are
// zero, absent noise models are H = 1, absent actuators linear. Throws InputError
// "<json path>: <what>".
Model make_model(std::string name, double sample_time_s, std::vector<std::string> inputs,
                 std::vector<std::string> outputs, const ProcessChannels& process,
                 const NoiseModels& noise, const ActuatorSpecs& actuators = {});

// Checks the invariants of a Model built by hand (dimensions, names, noise models
// monic / stable / minimum phase, sample time). Throws InputError "<json path>: <what>".
void validate_model(const Model& model);

// `source` names the text in error messages (the file path for load_model).
Model parse_model(const std::string& json_text, const std::string& source);
Model load_model(const std::string& path);

// The discrete form, keys in file order, numbers written so they read back exactly.
std::string model_to_json(const Model& model);
// Atomic: written to a temporary file in the same directory, then renamed over `path`.
void save_model(const Model& model, const std::string& path);

}  // namespace mpmpp
