#include "mpmpp/model_io.hpp"

#include <pybind11/eigen.h>
#include <pybind11/stl.h>

#include "bindings.hpp"
#include "mpmpp/error.hpp"

namespace py = pybind11;

namespace mpmpp::bindings {

namespace {

int index_of(const std::vector<std::string>& names, const std::string& name, const char* kind) {
  for (std::size_t i = 0; i < names.size(); ++i)
    if (names[i] == name) return static_cast<int>(i);
  throw InputError(std::string("unknown ") + kind + " \"" + name + "\"");
}

ProcessChannels process_dict(const Model& m) {
  ProcessChannels p;
  for (int i = 0; i < m.num_outputs(); ++i)
    for (int j = 0; j < m.num_inputs(); ++j)
      if (m.has_channel(i, j)) p[m.outputs[i]].emplace(m.inputs[j], *m.process[i][j]);
  return p;
}

NoiseModels noise_dict(const Model& m) {
  NoiseModels n;
  for (int i = 0; i < m.num_outputs(); ++i) n.emplace(m.outputs[i], m.noise[i]);
  return n;
}

// Python sees an actuator as a dict {"kind": ..., parameter: value, ..., "confidence": c}.
ActuatorSpecs actuators_from_python(const py::dict& d) {
  ActuatorSpecs out;
  for (const auto& item : d) {
    const std::string input = py::str(item.first);
    const py::dict block = py::reinterpret_borrow<py::dict>(item.second);
    ActuatorSpec a;
    for (const auto& field : block) {
      const std::string key = py::str(field.first);
      if (key == "kind")
        a.kind = py::str(field.second);
      else
        (key == "confidence" ? a.confidence : a.parameters[key]) = field.second.cast<double>();
    }
    out.emplace(input, a);
  }
  return out;
}

py::dict actuator_to_python(const ActuatorSpec& a) {
  py::dict d;
  d["kind"] = a.kind;
  for (const auto& [name, value] : a.parameters) d[py::str(name)] = value;
  if (a.confidence >= 0.0) d["confidence"] = a.confidence;
  return d;
}

}  // namespace

void bind_model_io(py::module_& m) {
  py::class_<Model>(
      m, "Model",
      "The nominal model (docs/formats.md 'Model file'): process[output][input] channels "
      "(absent = zero) and noise[output] models (absent = 1).")
      .def(py::init([](std::string name, double ts, std::vector<std::string> inputs,
                       std::vector<std::string> outputs, const ProcessChannels& process,
                       const NoiseModels& noise, const py::dict& actuators) {
             return make_model(std::move(name), ts, std::move(inputs), std::move(outputs), process,
                               noise, actuators_from_python(actuators));
           }),
           py::arg("name"), py::arg("sample_time_s"), py::arg("inputs"), py::arg("outputs"),
           py::arg("process") = ProcessChannels{}, py::arg("noise") = NoiseModels{},
           py::arg("actuators") = py::dict(),
           "process: {output: {input: TransferFunction}}, noise: {output: TransferFunction}, "
           "actuators: {input: {'kind': 'stick_slip', 'S': ..., 'J': ...}} (docs/stiction.md "
           "'Model file')")
      .def_readonly("name", &Model::name)
      .def_readonly("sample_time_s", &Model::sample_time_s)
      .def_readonly("inputs", &Model::inputs)
      .def_readonly("outputs", &Model::outputs)
      .def(
          "process",
          [](const Model& self, const std::string& output, const std::string& input) {
            return self.process[index_of(self.outputs, output, "output")]
                               [index_of(self.inputs, input, "input")];
          },
          py::arg("output"), py::arg("input"),
          "The channel output <- input, or None if the model has none")
      .def(
          "noise",
          [](const Model& self, const std::string& output) {
            return self.noise[index_of(self.outputs, output, "output")];
          },
          py::arg("output"))
      .def(
          "channels",
          [](const Model& self) {
            std::vector<std::pair<std::string, std::string>> out;
            for (int i = 0; i < self.num_outputs(); ++i)
              for (int j = 0; j < self.num_inputs(); ++j)
                if (self.has_channel(i, j)) out.emplace_back(self.outputs[i], self.inputs[j]);
            return out;
          },
          "(output, input) of every channel the model has")
      .def(
          "actuator",
          [](const Model& self, const std::string& input) -> py::object {
            const auto& a = self.actuators[index_of(self.inputs, input, "input")];
            return a ? py::object(actuator_to_python(*a)) : py::none();
          },
          py::arg("input"), "The valve model of input (a dict), or None for a linear valve")
      .def(
          "actuators_dict",
          [](const Model& self) {
            py::dict d;
            for (int j = 0; j < self.num_inputs(); ++j)
              if (self.actuators[j])
                d[py::str(self.inputs[j])] = actuator_to_python(*self.actuators[j]);
            return d;
          },
          "{input: actuator dict} for the inputs that have one, to build a changed Model")
      .def("process_dict", &process_dict,
           "{output: {input: TransferFunction}}, to build a changed Model")
      .def("noise_dict", &noise_dict, "{output: TransferFunction} for every output")
      .def("to_json", &model_to_json)
      .def_static("from_json", &parse_model, py::arg("text"), py::arg("source") = "<string>")
      .def(
          "__eq__",
          [](const Model& a, const Model& b) { return model_to_json(a) == model_to_json(b); },
          py::is_operator())
      .def("__repr__", [](const Model& self) {
        return "<mpmpp.Model '" + self.name + "': " + std::to_string(self.num_inputs()) +
               " inputs, " + std::to_string(self.num_outputs()) +
               " outputs, Ts = " + py::repr(py::float_(self.sample_time_s)).cast<std::string>() +
               " s>";
      });
  m.def("load_model", &load_model, py::arg("path"));
  m.def("save_model", &save_model, py::arg("model"), py::arg("path"));
}

}  // namespace mpmpp::bindings
