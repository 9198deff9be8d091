// What a job asks for: the options of `matfit fit` / `matfit leaf` that the API accepts, parsed
// from form fields or a JSON body with errors that name the field.
#pragma once

#include <map>
#include <nlohmann/json_fwd.hpp>
#include <string>

#include "core/status.h"

namespace matfit::server {

struct JobSpec {
  std::string mode = "fit";  // "fit" | "leaf"
  std::string model = "lambert-robust";
  std::string view;             // "THETA,PHI" (BTF view), "all" (every view) or empty
  int holdout = 0;              // k-fold held-out-light error (fit); fit::kLeaveOneOut for "loo"
  double budget = 0;            // model "auto": held-out RMSE budget (0 = the default scene's)
  std::string layout = "auto";  // dataset layout (fit): auto, bonn, utia, lp, diligent, …
  std::string color_space = "auto";  // image encoding (fit): auto, srgb, linear
  nlohmann::json ToJson() const;
};

// `fields`: name → value as text (multipart form fields, or JSON values already checked by
// ParseJobSpecJson). Unknown fields and bad values give kInvalidArgument naming the field.
StatusOr<JobSpec> ParseJobSpecFields(const std::map<std::string, std::string>& fields);
// JSON body: {"dataset": "/path", "model": "...", "view": "θ,φ", "mode": "leaf", "holdout": 4}.
// *dataset receives the dataset path.
StatusOr<JobSpec> ParseJobSpecJson(const std::string& body, std::string* dataset);
StatusOr<JobSpec> JobSpecFromJson(const std::string& stored);  // as written by ToJson

// The field a kInvalidArgument message from the parsers is about ("" when not a field).
std::string FieldOfError(const std::string& message);

}  // namespace matfit::server
