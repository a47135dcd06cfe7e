#pragma once
// Internal: DetectorConfig <-> nlohmann::json, shared by the config file reader and
// the detector file (which embeds its config). Not installed: nlohmann stays private.
#include <nlohmann/json.hpp>

#include "mpmpp/detector_config.hpp"

namespace mpmpp::detail {

nlohmann::json config_to_json(const DetectorConfig& c);
// `where` prefixes error messages (e.g. "config" or "detector file: config").
DetectorConfig config_from_json(const nlohmann::json& j, const std::string& where);

}  // namespace mpmpp::detail
