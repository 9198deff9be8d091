#include "server/job_spec.h"

#include <cmath>
#include <cstdlib>
#include <nlohmann/json.hpp>

#include "core/color.h"
#include "core/dataset/dataset.h"
#include "fit/holdout.h"
#include "fit/method.h"
#include "server/text.h"

namespace matfit::server {
namespace {

using json = nlohmann::json;

// Messages start with "field 'NAME': " so the HTTP layer can name it in the error body.
Status FieldError(const std::string& field, const std::string& why) {
  return InvalidArgument("field '" + field + "': " + why);
}

bool ParseView(const std::string& s, double* theta, double* phi) {
  const auto comma = s.find(',');
  if (comma == std::string::npos) return false;
  char* end = nullptr;
  const std::string a = s.substr(0, comma), b = s.substr(comma + 1);
  *theta = std::strtod(a.c_str(), &end);
  if (a.empty() || *end) return false;
  *phi = std::strtod(b.c_str(), &end);
  if (b.empty() || *end) return false;
  return *theta >= 0 && *theta <= 90 && *phi >= -360 && *phi <= 360;
}

}  // namespace

json JobSpec::ToJson() const {
  return {{"mode", mode},
          {"model", model},
          {"view", view},
          {"holdout", holdout == fit::kLeaveOneOut ? json("loo") : json(holdout)},
          {"budget", budget},
          {"layout", layout},
          {"color_space", color_space}};
}

StatusOr<JobSpec> ParseJobSpecFields(const std::map<std::string, std::string>& fields) {
  JobSpec s;
  for (const auto& [k, v] : fields) {
    if (k == "mode") {
      if (v != "fit" && v != "leaf")
        return FieldError("mode", "must be fit or leaf, got '" + v + "'");
      s.mode = v;
    } else if (k == "model") {
      s.model = v;
    } else if (k == "view") {
      double t, p;
      if (!v.empty() && v != "all" && !ParseView(v, &t, &p))
        return FieldError("view",
                          "must be THETA,PHI in degrees (θ in [0, 90]) or all, got '" + v + "'");
      s.view = v;
    } else if (k == "holdout") {
      char* end = nullptr;
      const long h = std::strtol(v.c_str(), &end, 10);
      if (v == "loo")
        s.holdout = fit::kLeaveOneOut;
      else if (v.empty() || *end || h < 0 || h == 1 || h > 1000)
        return FieldError(
            "holdout", "must be 0 (off), a fold count ≥ 2 or loo (leave-one-out), got '" + v + "'");
      else
        s.holdout = int(h);
    } else if (k == "budget") {
      char* end = nullptr;
      const double b = std::strtod(v.c_str(), &end);
      if (v.empty() || *end || !(b > 0) || !std::isfinite(b))
        return FieldError("budget", "must be a positive held-out RMSE (linear), got '" + v + "'");
      s.budget = b;
    } else if (k == "layout") {
      Layout l;
      if (!ParseLayout(v, &l)) {
        std::string list = "auto";
        for (const auto& n : LayoutNames()) list += ", " + n;
        return FieldError("layout", "must be one of " + list + ", got '" + v + "'");
      }
      s.layout = LayoutName(l);
    } else if (k == "color_space") {
      ColorSpaceChoice c;
      if (!ParseColorSpaceChoice(v, &c))
        return FieldError("color_space", "must be auto, srgb or linear, got '" + v + "'");
      s.color_space = v == "sRGB" ? "srgb" : v;
    } else if (k != "file" && k != "dataset") {
      return FieldError(k,
                        "is not an option; use model, view, mode, holdout, budget, layout, "
                        "color_space (and file or dataset)");
    }
  }
  if (s.mode == "fit") {
    if (s.budget > 0 && s.model != "auto")
      return FieldError("budget", "applies to model=auto only");
    bool known = s.model == "auto";
    std::string list;
    std::vector<std::string> names = fit::MethodNames();
    for (const auto& n : fit::MultiViewMethodNames()) names.push_back(n);
    for (const auto& n : names) list += (list.empty() ? "" : ", ") + n;
    list += ", per-view:<one of the first " + std::to_string(fit::MethodNames().size()) + ">";
    for (const auto& n : fit::PerViewMethodNames()) names.push_back(n);
    for (const auto& n : names) known = known || n == s.model;
    if (!known)
      return FieldError("model",
                        "'" + s.model + "' is not a model; choose one of: " + list + " or auto");
  } else {
    for (const char* k : {"model", "view", "holdout", "budget", "layout", "color_space"})
      if (fields.count(k)) return FieldError(k, "does not apply to mode=leaf");
  }
  return s;
}

StatusOr<JobSpec> ParseJobSpecJson(const std::string& body, std::string* dataset) {
  json j;
  try {
    j = json::parse(body);
  } catch (const json::exception& e) {  // parse_error names the offset; out_of_range: 1e999
    return InvalidArgument(std::string("the body is not valid JSON: ") + e.what());
  }
  if (!j.is_object()) return InvalidArgument("the body must be a JSON object");
  if (!j.contains("dataset")) return FieldError("dataset", "is required (a folder on the server)");
  if (!j["dataset"].is_string() || j["dataset"].get<std::string>().empty())
    return FieldError("dataset", "must be a non-empty string (a folder on the server)");
  *dataset = j["dataset"].get<std::string>();
  std::map<std::string, std::string> fields;
  for (const auto& [k, v] : j.items()) {
    if (k == "dataset") continue;
    if (k == "holdout") {
      if (v.is_string() && v.get<std::string>() == "loo")
        fields[k] = "loo";
      else if (!v.is_number_integer())
        return FieldError("holdout", "must be an integer fold count or \"loo\"");
      else
        fields[k] = std::to_string(v.get<int64_t>());
    } else if (k == "budget") {
      if (!v.is_number()) return FieldError("budget", "must be a number");
      fields[k] = JsonText(v);
    } else if (v.is_string()) {
      fields[k] = v.get<std::string>();
    } else {
      return FieldError(k, "must be a string");
    }
  }
  return ParseJobSpecFields(fields);
}

StatusOr<JobSpec> JobSpecFromJson(const std::string& stored) {
  const json j = json::parse(stored, nullptr, false);
  if (!j.is_object()) return DataError("stored job spec is not a JSON object");
  // Every value is type- and range-checked: a stored row is data, not trusted code.
  std::map<std::string, std::string> fields;
  for (const auto& [k, v] : j.items()) {
    if (v.is_string()) {
      fields[k] = v.get<std::string>();
    } else if (k == "holdout" && v.is_number_integer() && v.get<double>() >= 0 &&
               v.get<double>() <= 1000) {
      fields[k] = std::to_string(v.get<int64_t>());
    } else if (k == "budget" && v.is_number()) {
      if (v.get<double>() != 0) fields[k] = JsonText(v);  // 0: the default, not a value
    } else if (!(k == "holdout" && v.is_number_integer() && v.get<int64_t>() == 0)) {
      return DataError("stored job spec: field '" + k + "' has the wrong type");
    }
  }
  if (fields.count("holdout") && fields["holdout"] == "0") fields.erase("holdout");
  for (const char* k : {"view", "layout", "color_space"})  // defaults stored as "" / "auto"
    if (fields.count(k) && (fields[k].empty() || fields[k] == "auto")) fields.erase(k);
  if (fields.count("mode") && fields["mode"] == "leaf") fields.erase("model");
  auto s = ParseJobSpecFields(fields);
  if (!s.ok()) return DataError("stored job spec: " + s.status().message());
  return s;
}

std::string FieldOfError(const std::string& message) {
  const std::string p = "field '";
  if (message.rfind(p, 0) != 0) return "";
  const auto end = message.find('\'', p.size());
  return end == std::string::npos ? "" : message.substr(p.size(), end - p.size());
}

}  // namespace matfit::server
