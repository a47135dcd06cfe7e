#include "mpmpp/model_io.hpp"

#include <cmath>
#include <nlohmann/json.hpp>
#include <set>

#include "mpmpp/error.hpp"
#include "mpmpp/limits.hpp"
#include "text_file.hpp"

namespace mpmpp {

namespace {

using json = nlohmann::json;

// A JSON path such as "process.dry_weight.stock_flow" or "inputs[1]".
std::string join(const std::string& path, const std::string& key) {
  return path.empty() ? key : path + "." + key;
}
std::string index(const std::string& path, std::size_t i) {
  return path + "[" + std::to_string(i) + "]";
}

[[noreturn]] void fail(const std::string& path, const std::string& what) {
  throw InputError(path.empty() ? what : path + ": " + what);
}

// Runs `make` and puts `path` in front of the message of an InputError it throws
// (the TransferFunction constructor and from_foptd do not know where they are).
template <class Make>
auto at(const std::string& path, Make make) -> decltype(make()) {
  try {
    return make();
  } catch (const InputError& e) {
    fail(path, e.what());
  }
}

std::string quoted(const std::string& s) { return "\"" + s + "\""; }

using detail::format_number;

void expect_type(const json& j, bool ok, const char* expected, const std::string& path) {
  if (!ok) fail(path, std::string("must be ") + expected + ", got " + j.type_name());
}

void expect_object(const json& j, const std::string& path) {
  expect_type(j, j.is_object(), "an object", path);
}

// Unknown keys are an error (docs/formats.md): a typo must not be silently ignored.
void check_keys(const json& obj, const std::string& path, const std::vector<std::string>& allowed) {
  for (const auto& item : obj.items()) {
    bool known = false;
    for (const auto& a : allowed) known = known || item.key() == a;
    if (!known)
      fail(join(path, item.key()),
           "unknown key (expected one of: " + detail::comma_list(allowed) + ")");
  }
}

const json& field(const json& obj, const std::string& key, const std::string& path) {
  auto it = obj.find(key);
  if (it == obj.end()) fail(path, "missing field " + quoted(key));
  return *it;
}

double finite_number(const json& j, const std::string& path) {
  expect_type(j, j.is_number(), "a number", path);
  const double x = j.get<double>();
  if (!std::isfinite(x)) fail(path, "must be finite");
  if (std::abs(x) >= kLargestValue)
    fail(path, "too large to compute with, got " + format_number(x) +
                   " (magnitude 1e100 or more: its squares overflow); check the units");
  return x;
}

Eigen::VectorXd coefficients(const json& j, const std::string& path) {
  expect_type(j, j.is_array(), "an array of numbers", path);
  if (j.empty()) fail(path, "must have at least one coefficient");
  Eigen::VectorXd c(static_cast<Eigen::Index>(j.size()));
  for (std::size_t i = 0; i < j.size(); ++i)
    c[static_cast<Eigen::Index>(i)] = finite_number(j[i], index(path, i));
  return c;
}

// Delays are whole samples; 3.0 is accepted as 3, 2.5 is an error (use the
// continuous FOPTD form for a fractional dead time).
int delay_samples(const json& j, const std::string& path) {
  constexpr double kMaxDelay = 1e6;  // far beyond any plant, and safe to cast
  expect_type(j, j.is_number(), "an integer", path);
  const double d = j.get<double>();
  if (!(d >= 0.0)) fail(path, "must be >= 0, got " + format_number(d));
  if (d != std::floor(d))
    fail(path, "must be an integer number of samples, got " + format_number(d));
  if (d > kMaxDelay) fail(path, "must be <= 1000000 samples, got " + format_number(d));
  return static_cast<int>(d);
}

std::vector<std::string> names(const json& j, const std::string& path) {
  expect_type(j, j.is_array(), "an array of names", path);
  std::vector<std::string> out;
  for (std::size_t i = 0; i < j.size(); ++i) {
    expect_type(j[i], j[i].is_string(), "a string", index(path, i));
    out.push_back(j[i].get<std::string>());
  }
  return out;
}

TransferFunction discrete_channel(const json& j, const std::string& path, bool with_delay) {
  const Eigen::VectorXd num = coefficients(field(j, "num", path), join(path, "num"));
  const Eigen::VectorXd den = coefficients(field(j, "den", path), join(path, "den"));
  const int delay =
      with_delay && j.contains("delay") ? delay_samples(j["delay"], join(path, "delay")) : 0;
  return at(path, [&] { return TransferFunction(num, den, delay); });
}

TransferFunction process_channel(const json& j, const std::string& path, double sample_time_s) {
  expect_object(j, path);
  const bool foptd =
      j.contains("gain") || j.contains("time_constant_s") || j.contains("dead_time_s");
  if (!foptd) {
    check_keys(j, path, {"num", "den", "delay"});
    return discrete_channel(j, path, true);
  }
  check_keys(j, path, {"gain", "time_constant_s", "dead_time_s"});
  const double gain = finite_number(field(j, "gain", path), join(path, "gain"));
  const double tau =
      finite_number(field(j, "time_constant_s", path), join(path, "time_constant_s"));
  const double theta = finite_number(field(j, "dead_time_s", path), join(path, "dead_time_s"));
  return at(path, [&] { return TransferFunction::from_foptd(gain, tau, theta, sample_time_s); });
}

void check_names(const std::vector<std::string>& names, const std::string& path,
                 const std::vector<std::string>& other, const char* other_kind) {
  if (names.empty()) fail(path, "must name at least one variable");
  std::set<std::string> seen;
  for (std::size_t i = 0; i < names.size(); ++i) {
    const std::string& n = names[i];
    if (n.empty()) fail(index(path, i), "empty name");
    for (unsigned char c : n)
      if (c < 0x20 || c == 0x7f) fail(index(path, i), "name contains a control character");
    if (n == "time") fail(index(path, i), "\"time\" is reserved for the data file's time column");
    if (!seen.insert(n).second) fail(index(path, i), "duplicate name " + quoted(n));
    for (const auto& o : other)
      if (o == n) fail(index(path, i), quoted(n) + " is also " + other_kind);
  }
}

int position(const std::vector<std::string>& names, const std::string& name) {
  for (std::size_t i = 0; i < names.size(); ++i)
    if (names[i] == name) return static_cast<int>(i);
  return -1;
}

int lookup(const std::vector<std::string>& names, const std::string& name, const char* kind,
           const std::string& path) {
  const int i = position(names, name);
  if (i < 0)
    fail(path, "unknown " + std::string(kind) + " " + quoted(name) + " (" + kind +
                   "s: " + detail::comma_list(names) + ")");
  return i;
}

double largest_magnitude(const Eigen::VectorXcd& roots) {
  return roots.size() == 0 ? 0.0 : roots.cwiseAbs().maxCoeff();
}

// The disturbance model of the paper's Box-Jenkins structure y = G u + H e must be
// monic (H(inf) = 1, so e is the one-step prediction error), stable, and inversely
// stable (the predictor filters y through H^-1).
void check_noise(const TransferFunction& h, const std::string& path) {
  // Its roots are computed below (an eigenvalue problem cubic in the order): a hostile
  // 10^4-coefficient polynomial must not stall loading for minutes.
  constexpr Eigen::Index kMaxNoiseCoefficients = 200;
  if (h.num().size() > kMaxNoiseCoefficients || h.den().size() > kMaxNoiseCoefficients)
    fail(path, "at most 200 coefficients in num and in den");
  if (h.delay() != 0) fail(path, "delay must be 0 (the noise model is monic)");
  if (std::abs(h.num()[0] - 1.0) > 1e-12)
    fail(path,
         "must be monic (num[0] == den[0]), got num[0]/den[0] = " + format_number(h.num()[0]));
  if (!h.is_stable())
    fail(path,
         "unstable: a pole has |z| = " + format_number(largest_magnitude(h.poles())) + " >= 1");
  if (!h.is_minimum_phase())
    fail(path,
         "non-minimum-phase: a zero has |z| = " + format_number(largest_magnitude(h.zeros())) +
             " >= 1 (H must be inversely stable)");
}

// Parameters of each actuator kind, in file order.
const std::map<std::string, std::vector<std::string>>& actuator_parameters() {
  static const std::map<std::string, std::vector<std::string>> kinds = {
      {"stick_slip", {"S", "J"}},
      {"he", {"fs", "fd"}},
      {"backlash", {"S"}},
      {"deadband", {"width"}},
      {"saturation", {"lower", "upper"}}};
  return kinds;
}

std::vector<std::string> kind_names() {
  std::vector<std::string> out;
  for (const auto& [kind, params] : actuator_parameters()) out.push_back(kind);
  return out;
}

void check_actuator(const ActuatorSpec& a, const std::string& path) {
  const auto kind = actuator_parameters().find(a.kind);
  if (kind == actuator_parameters().end())
    fail(join(path, "kind"), "unknown kind " + quoted(a.kind) +
                                 " (expected one of: " + detail::comma_list(kind_names()) + ")");
  for (const auto& p : kind->second)
    if (!a.parameters.count(p))
      fail(path, "missing field " + quoted(p) + " for kind " + quoted(a.kind));
  for (const auto& [name, value] : a.parameters) {
    bool known = false;
    for (const auto& p : kind->second) known = known || p == name;
    if (!known) fail(join(path, name), "not a parameter of kind " + quoted(a.kind));
    if (!std::isfinite(value)) fail(join(path, name), "must be finite");
  }
  auto nonnegative = [&](const char* p) {
    if (a.parameters.at(p) < 0.0)
      fail(join(path, p), "must be >= 0, got " + format_number(a.parameters.at(p)));
  };
  if (a.kind == "stick_slip") {
    nonnegative("S");
    nonnegative("J");
    if (a.parameters.at("J") > a.parameters.at("S"))
      fail(join(path, "J"), "must be <= S (the slip jump cannot exceed the band)");
  } else if (a.kind == "he") {
    nonnegative("fs");
    nonnegative("fd");
    if (a.parameters.at("fd") > a.parameters.at("fs"))
      fail(join(path, "fd"), "must be <= fs (dynamic friction cannot exceed static friction)");
  } else if (a.kind == "backlash") {
    nonnegative("S");
  } else if (a.kind == "deadband") {
    nonnegative("width");
  } else if (!(a.parameters.at("lower") < a.parameters.at("upper"))) {
    fail(join(path, "upper"), "must be > lower");
  }
  if (a.confidence >= 0.0 ? a.confidence > 1.0 : a.confidence != -1.0)
    fail(join(path, "confidence"), "must be between 0 and 1, got " + format_number(a.confidence));
}

ActuatorSpec actuator_from_json(const json& j, const std::string& path) {
  expect_object(j, path);
  ActuatorSpec a;
  const json& kind = field(j, "kind", path);
  expect_type(kind, kind.is_string(), "a string", join(path, "kind"));
  a.kind = kind.get<std::string>();
  for (const auto& item : j.items()) {
    if (item.key() == "kind") continue;
    const double x = finite_number(item.value(), join(path, item.key()));
    (item.key() == "confidence" ? a.confidence : a.parameters[item.key()]) = x;
  }
  check_actuator(a, path);
  return a;
}

// The optional, versioned block {"version": 1, "inputs": {input: {kind, parameters...}}}.
ActuatorSpecs actuators_from_json(const json& block) {
  expect_object(block, "actuators");
  check_keys(block, "actuators", {"version", "inputs"});
  const json& v = field(block, "version", "actuators");
  expect_type(v, v.is_number_integer() || v.is_number_unsigned(), "an integer",
              "actuators.version");
  if (v.get<long long>() != kActuatorsVersion)
    fail("actuators.version", "version " + v.dump() +
                                  " is not supported (this library reads version " +
                                  std::to_string(kActuatorsVersion) + ")");
  const json& inputs = field(block, "inputs", "actuators");
  expect_object(inputs, "actuators.inputs");
  ActuatorSpecs out;
  for (const auto& item : inputs.items())
    out.emplace(item.key(), actuator_from_json(item.value(), join("actuators.inputs", item.key())));
  return out;
}

nlohmann::ordered_json actuator_json(const ActuatorSpec& a) {
  nlohmann::ordered_json j;
  j["kind"] = a.kind;
  for (const auto& p : actuator_parameters().at(a.kind)) j[p] = a.parameters.at(p);
  if (a.confidence >= 0.0) j["confidence"] = a.confidence;
  return j;
}

// Rejects duplicate keys while parsing (nlohmann keeps the last one silently).
// Arrays in a model file hold only numbers and names, so the object keys alone
// give the path of the duplicate.
class DuplicateKeyCheck {
 public:
  bool operator()(int depth, json::parse_event_t event, json& parsed) {
    switch (event) {
      case json::parse_event_t::object_start:
        scopes_.emplace_back();
        break;
      case json::parse_event_t::key: {
        const std::string key = parsed.get<std::string>();
        while (!path_.empty() && path_.back().first >= depth) path_.pop_back();
        if (!scopes_.back().insert(key).second) {
          std::string path;
          for (const auto& entry : path_) path = join(path, entry.second);
          fail(join(path, key), "duplicate key");
        }
        path_.emplace_back(depth, key);
        break;
      }
      case json::parse_event_t::object_end:
        scopes_.pop_back();
        break;
      default:
        break;
    }
    return true;
  }

 private:
  std::vector<std::set<std::string>> scopes_;
  std::vector<std::pair<int, std::string>>
      path_;  // (depth, key) of the enclosing objects' current keys
};

Model model_from_json(const json& root) {
  expect_object(root, "top level");
  check_keys(root, "",
             {"name", "sample_time_s", "inputs", "outputs", "process", "noise", "actuators"});
  std::string name;
  if (root.contains("name")) {
    expect_type(root["name"], root["name"].is_string(), "a string", "name");
    name = root["name"].get<std::string>();
  }
  const double ts = finite_number(field(root, "sample_time_s", ""), "sample_time_s");
  if (!(ts > 0.0)) fail("sample_time_s", "must be > 0, got " + format_number(ts));
  const std::vector<std::string> inputs = names(field(root, "inputs", ""), "inputs");
  const std::vector<std::string> outputs = names(field(root, "outputs", ""), "outputs");
  check_names(inputs, "inputs", {}, "");
  check_names(outputs, "outputs", inputs, "an input");

  ProcessChannels process;
  const json& p = field(root, "process", "");
  expect_object(p, "process");
  for (const auto& row : p.items()) {
    const std::string row_path = join("process", row.key());
    lookup(outputs, row.key(), "output", row_path);
    expect_object(row.value(), row_path);
    for (const auto& ch : row.value().items()) {
      const std::string path = join(row_path, ch.key());
      lookup(inputs, ch.key(), "input", path);
      process[row.key()].emplace(ch.key(), process_channel(ch.value(), path, ts));
    }
  }
  NoiseModels noise;
  if (root.contains("noise")) {
    const json& n = root["noise"];
    expect_object(n, "noise");
    for (const auto& item : n.items()) {
      const std::string path = join("noise", item.key());
      lookup(outputs, item.key(), "output", path);
      expect_object(item.value(), path);
      check_keys(item.value(), path, {"num", "den"});
      noise.emplace(item.key(), discrete_channel(item.value(), path, false));
    }
  }
  const ActuatorSpecs actuators =
      root.contains("actuators") ? actuators_from_json(root["actuators"]) : ActuatorSpecs{};
  return make_model(std::move(name), ts, inputs, outputs, process, noise, actuators);
}

nlohmann::ordered_json discrete_json(const TransferFunction& g, bool with_delay) {
  nlohmann::ordered_json j;
  j["num"] = std::vector<double>(g.num().data(), g.num().data() + g.num().size());
  j["den"] = std::vector<double>(g.den().data(), g.den().data() + g.den().size());
  if (with_delay) j["delay"] = g.delay();
  return j;
}

}  // namespace

void validate_model(const Model& m) {
  if (!(m.sample_time_s > 0.0) || !std::isfinite(m.sample_time_s))
    fail("sample_time_s", "must be > 0 and finite, got " + format_number(m.sample_time_s));
  check_names(m.inputs, "inputs", {}, "");
  check_names(m.outputs, "outputs", m.inputs, "an input");
  if (m.process.size() != m.outputs.size())
    fail("process", "has " + std::to_string(m.process.size()) + " rows for " +
                        std::to_string(m.outputs.size()) + " outputs");
  for (std::size_t i = 0; i < m.process.size(); ++i)
    if (m.process[i].size() != m.inputs.size())
      fail(join("process", m.outputs[i]), "has " + std::to_string(m.process[i].size()) +
                                              " channels for " + std::to_string(m.inputs.size()) +
                                              " inputs");
  if (m.noise.size() != m.outputs.size())
    fail("noise", "has " + std::to_string(m.noise.size()) + " models for " +
                      std::to_string(m.outputs.size()) + " outputs");
  for (std::size_t i = 0; i < m.noise.size(); ++i)
    check_noise(m.noise[i], join("noise", m.outputs[i]));
  if (!m.actuators.empty() && m.actuators.size() != m.inputs.size())
    fail("actuators", "has " + std::to_string(m.actuators.size()) + " entries for " +
                          std::to_string(m.inputs.size()) + " inputs");
  for (std::size_t j = 0; j < m.actuators.size(); ++j)
    if (m.actuators[j]) check_actuator(*m.actuators[j], join("actuators.inputs", m.inputs[j]));
}

Model make_model(std::string name, double sample_time_s, std::vector<std::string> inputs,
                 std::vector<std::string> outputs, const ProcessChannels& process,
                 const NoiseModels& noise, const ActuatorSpecs& actuators) {
  Model m;
  m.name = std::move(name);
  m.sample_time_s = sample_time_s;
  m.inputs = std::move(inputs);
  m.outputs = std::move(outputs);
  check_names(m.inputs, "inputs", {}, "");
  check_names(m.outputs, "outputs", m.inputs, "an input");
  m.process.assign(m.outputs.size(), std::vector<std::optional<TransferFunction>>(m.inputs.size()));
  m.noise.assign(m.outputs.size(), TransferFunction());
  for (const auto& [output, row] : process) {
    const std::string row_path = join("process", output);
    const int i = lookup(m.outputs, output, "output", row_path);
    for (const auto& [input, g] : row)
      m.process[i][lookup(m.inputs, input, "input", join(row_path, input))] = g;
  }
  for (const auto& [output, h] : noise)
    m.noise[lookup(m.outputs, output, "output", join("noise", output))] = h;
  m.actuators.assign(m.inputs.size(), std::nullopt);
  for (const auto& [input, a] : actuators)
    m.actuators[lookup(m.inputs, input, "input", join("actuators.inputs", input))] = a;
  validate_model(m);
  return m;
}

Model parse_model(const std::string& json_text, const std::string& source) {
  try {
    if (json_text.find_first_not_of(" \t\r\n") == std::string::npos)
      throw InputError("file is empty");
    json root;
    try {
      root = json::parse(json_text, DuplicateKeyCheck());
    } catch (const json::exception& e) {  // parse_error, or out_of_range 406 for 1e400
      // what() is "[json.exception.parse_error.101] parse error at line 1, column 1: ...".
      std::string what = e.what();
      const auto start = what.find("] ");
      if (start != std::string::npos) what = what.substr(start + 2);
      throw InputError("not valid JSON: " + detail::printable(what, 200));
    }
    return model_from_json(root);
  } catch (const InputError& e) {
    throw InputError(detail::one_line(source + ": " + e.what()));
  }
}

Model load_model(const std::string& path) {
  return parse_model(detail::read_text_file(path), path);
}

std::string model_to_json(const Model& m) {
  validate_model(m);
  nlohmann::ordered_json root;
  root["name"] = m.name;
  root["sample_time_s"] = m.sample_time_s;
  root["inputs"] = m.inputs;
  root["outputs"] = m.outputs;
  root["process"] = nlohmann::ordered_json::object();
  for (int i = 0; i < m.num_outputs(); ++i)
    for (int j = 0; j < m.num_inputs(); ++j)
      if (m.has_channel(i, j))
        root["process"][m.outputs[i]][m.inputs[j]] = discrete_json(*m.process[i][j], true);
  // H = 1 is what an absent entry means, so it is left out.
  auto noise = nlohmann::ordered_json::object();
  for (int i = 0; i < m.num_outputs(); ++i)
    if (!(m.noise[i] == TransferFunction())) noise[m.outputs[i]] = discrete_json(m.noise[i], false);
  if (!noise.empty()) root["noise"] = noise;
  // Written only when an input has one, so a file without actuators saves as before.
  if (m.has_actuators()) {
    auto inputs = nlohmann::ordered_json::object();
    for (int j = 0; j < m.num_inputs(); ++j)
      if (m.actuators[j]) inputs[m.inputs[j]] = actuator_json(*m.actuators[j]);
    root["actuators"] = {{"version", kActuatorsVersion}, {"inputs", inputs}};
  }
  return root.dump(2) + "\n";
}

void save_model(const Model& model, const std::string& path) {
  std::string text;
  try {
    text = model_to_json(model);
  } catch (const InputError& e) {
    throw InputError(path + ": " + e.what());
  }
  detail::write_file_atomic(path, text);
}

}  // namespace mpmpp
