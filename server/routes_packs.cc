// GET /api/v1/packs/{id}[/…]: packs by the id of the job that made them (zip, files, report,
// cached previews) and the WebGL2 viewer.
#include <cerrno>
#include <cstdio>
#include <filesystem>
#include <fstream>

#include "core/atomic_file.h"
#include "core/pack/pack.h"
#include "core/path_util.h"
#include "render/render_options.h"
#include "server/log.h"
#include "server/server_impl.h"
#include "server/web_assets.h"

namespace matfit::server {
namespace {

namespace fs = std::filesystem;
using json = nlohmann::json;

std::string Num(double v) {
  char b[32];
  std::snprintf(b, sizeof b, "%.17g", v);  // exact: 30 and 30.000001 are different keys
  return b;
}

// Leaf packs of a leaf job, from its leaves.json (names like "leaf_01").
std::vector<std::string> LeafNames(const std::string& pack_dir) {
  std::ifstream in(pack_dir + "/leaves.json");
  const json j = json::parse(in, nullptr, false);
  std::vector<std::string> out;
  if (j.is_object() && j.contains("leaves") && j["leaves"].is_array())
    for (const auto& l : j["leaves"])
      if (l.is_object() && l.contains("name") && l["name"].is_string())
        out.push_back(l["name"].get<std::string>());
  return out;
}

bool ParseNumber(const std::string& s, double* v) {
  char* end = nullptr;
  *v = std::strtod(s.c_str(), &end);
  return !s.empty() && !*end && std::isfinite(*v);
}

}  // namespace

void Server::Impl::RegisterPackRoutes() {
  // The job must exist and have succeeded; otherwise an error response is sent.
  auto pack_of = [this](const std::string& id, httplib::Response& res) -> std::optional<JobRecord> {
    auto j = GetJob(id);
    if (!j) {
      SendError(res, 404, "no job '" + id + "'");
      return std::nullopt;
    }
    if (j->state != JobState::kSucceeded) {
      SendError(res, 409,
                std::string("job '") + id + "' is " + JobStateName(j->state) +
                    "; its pack exists once it has succeeded");
      return std::nullopt;
    }
    return j;
  };
  auto is_leaf = [](const JobRecord& j) {
    return json::parse(j.spec_json, nullptr, false).value("mode", "fit") == "leaf";
  };

  http.Get(R"(/api/v1/packs/([^/]+))",
           [=, this](const httplib::Request& req, httplib::Response& res) {
             const auto j = pack_of(req.matches[1], res);
             if (!j) return;
             const std::string zip = ZipPath(j->id);
             std::error_code ec;
             if (!fs::exists(zip, ec)) {  // built once, atomically, then served from the cache
               AtomicFile tmp(zip);
               if (Status st = ZipFolder(PackDir(j->id), tmp.temp_path()); !st.ok())
                 return SendError(res, 500, ForClients(st.message()));
               if (Status st = tmp.Commit(); !st.ok())
                 return SendError(res, 500, ForClients(st.message()));
             }
             res.set_header("Content-Disposition", "attachment; filename=\"" + j->id + ".zip\"");
             SendFile(res, zip, "application/zip");
           });

  http.Get(R"(/api/v1/packs/([^/]+)/report)",
           [=, this](const httplib::Request& req, httplib::Response& res) {
             const auto j = pack_of(req.matches[1], res);
             if (!j) return;
             SendFile(res, PackDir(j->id) + (is_leaf(*j) ? "/leaves.json" : "/report.json"),
                      "application/json");
           });

  http.Get(R"(/api/v1/packs/([^/]+)/preview\.png)", [=, this](const httplib::Request& req,
                                                              httplib::Response& res) {
    const auto j = pack_of(req.matches[1], res);
    if (!j) return;
    render::RenderOptions o;
    o.size = 256;
    const std::pair<const char*, double*> numbers[] = {{"theta", &o.theta_deg},
                                                       {"phi", &o.phi_deg},
                                                       {"camera_theta", &o.camera_theta_deg},
                                                       {"camera_phi", &o.camera_phi_deg},
                                                       {"ambient", &o.ambient},
                                                       {"exposure", &o.exposure}};
    for (const auto& [name, v] : numbers)
      if (req.has_param(name) && !ParseNumber(req.get_param_value(name), v))
        return SendError(res, 400, std::string("query '") + name + "' must be a number", name);
    if (req.has_param("size")) {
      double s;
      if (!ParseNumber(req.get_param_value("size"), &s) || s != std::floor(s) || s < 8 || s > 1024)
        return SendError(res, 400, "query 'size' must be an integer in [8, 1024]", "size");
      o.size = int(s);
    }
    if (req.has_param("scene")) {
      auto sc = render::ParseScene(req.get_param_value("scene"));
      if (!sc.ok()) return SendError(res, 400, sc.status().message(), "scene");
      o.scene = *sc;
    }
    std::string why;
    if (!o.Check(&why)) return SendError(res, 400, why);
    std::string pack = PackDir(j->id), leaf;
    if (is_leaf(*j)) {
      const auto names = LeafNames(pack);
      leaf = req.has_param("leaf") ? req.get_param_value("leaf") : names.empty() ? "" : names[0];
      if (std::find(names.begin(), names.end(), leaf) == names.end())
        return SendError(res, 404, "this leaf job has no leaf '" + leaf + "' (see leaves.json)",
                         "leaf");
      pack += "/" + leaf;
    }
    const std::string key =
        (leaf.empty() ? "" : leaf + "-") + render::SceneName(o.scene) + "-t" + Num(o.theta_deg) +
        "-p" + Num(o.phi_deg) + "-ct" + Num(o.camera_theta_deg) + "-cp" + Num(o.camera_phi_deg) +
        "-a" + Num(o.ambient) + "-e" + Num(o.exposure) + "-s" + std::to_string(o.size) + ".png";
    std::optional<std::string> png = preview_cache->Lookup(j->id, key);
    const bool hit = png.has_value();
    if (!hit) {
      auto rendered = previews->Render(pack, o);
      if (!rendered.ok() && rendered.status().code() == StatusCode::kUnavailable) {
        res.set_header("Retry-After", "1");
        return SendError(res, 503, rendered.status().message());
      }
      if (!rendered.ok())
        return SendError(res, 500, "preview failed: " + ForClients(rendered.status().message()));
      // Served only once it is cached: a preview that cannot be stored is an error, never an
      // empty or partial file (nor one cached for a day by the client).
      int err = 0;
      if (Status st = preview_cache->Store(j->id, key, *rendered, &err); !st.ok()) {
        LogEvent("error", "preview_cache", {{"id", j->id}, {"error", st.message()}});
        return SendError(res, err == ENOSPC ? 507 : 500,
                         st.message() + (err == ENOSPC ? "; the server's disk is full (free space "
                                                         "in its data folder and retry)"
                                                       : ""));
      }
      png = std::move(*rendered);
    }
    res.set_header("X-Matfit-Cache", hit ? "hit" : "miss");
    res.set_header("Cache-Control", "max-age=86400");
    res.set_content(std::move(*png), "image/png");
  });

  http.Get(R"(/api/v1/packs/([^/]+)/(.+))",
           [=, this](const httplib::Request& req, httplib::Response& res) {
             const auto j = pack_of(req.matches[1], res);
             if (!j) return;
             const std::string rel = req.matches[2];
             const std::string root = PackDir(j->id), path = root + "/" + rel;
             // No hidden files (temporaries), no escape from the pack folder.
             const bool hidden = rel[0] == '.' || rel.find("/.") != std::string::npos;
             std::error_code ec;
             if (hidden || !PathWithin(path, root) || !fs::is_regular_file(path, ec))
               return SendError(res, 404,
                                "pack '" + j->id + "' has no file '" + rel + "'" +
                                    (is_leaf(*j) && rel == "material.json"
                                         ? " (a leaf job has one pack per leaf: see leaves.json)"
                                         : ""));
             SendFile(res, path, PackFileType(rel));
           });

  // The viewer: a redirect to the embedded page with the pack (or every leaf pack) as its
  // URL parameters, so that the page's relative script and shader URLs resolve.
  auto viewer = [=, this](const httplib::Request& req, httplib::Response& res) {
    const auto j = pack_of(req.matches[1], res);
    if (!j) return;
    const std::string base = "/api/v1/packs/" + j->id + "/";
    std::string packs = base;
    if (is_leaf(*j)) {
      packs.clear();
      for (const auto& n : LeafNames(PackDir(j->id)))
        packs += (packs.empty() ? "" : ",") + base + n + "/";
    }
    std::string url =
        "/api/v1/viewer/static/index.html?pack=" + packs + "&shaders=/api/v1/viewer/static/";
    for (const auto& [k, v] : req.params)  // viewer options (theta, scene, token, ...) pass on
      if (k != "pack" && k != "shaders")
        url += "&" + httplib::detail::encode_query_param(k) + "=" +
               httplib::detail::encode_query_param(v);
    res.set_redirect(url, 302);
  };
  http.Get(R"(/api/v1/viewer/([0-9a-f]+))", viewer);
  http.Get(R"(/viewer/([0-9a-f]+))", viewer);
  http.Get(R"(/api/v1/viewer/static/([A-Za-z0-9._-]+))",
           [](const httplib::Request& req, httplib::Response& res) {
             const std::string name = req.matches[1];
             const auto body = WebAsset(name);
             if (body.empty()) return SendError(res, 404, "no viewer file '" + name + "'");
             res.set_content(std::string(body), ViewerFileType(name).c_str());
           });
}

}  // namespace matfit::server
