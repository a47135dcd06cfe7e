#pragma once
// Error types of the engine. InputError is what a user can fix (bad file, bad
// argument); pybind11 maps std::invalid_argument to ValueError and the CLI to
// exit code 2. NumericalError is a computation that could not give an answer
// (non-informative data, singular system); it maps to RuntimeError.
#include <stdexcept>
#include <string>

namespace mpmpp {

class InputError : public std::invalid_argument {
 public:
  using std::invalid_argument::invalid_argument;
};

class NumericalError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

}  // namespace mpmpp
