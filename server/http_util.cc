#include <cstdio>
#include <filesystem>
#include <memory>

#include "server/server_impl.h"
#include "server/text.h"

namespace matfit::server {

void SendJson(httplib::Response& res, int status, const nlohmann::json& body) {
  res.status = status;
  res.set_content(JsonText(body, 2) + "\n", "application/json");
}

void SendError(httplib::Response& res, int status, const std::string& message,
               const std::string& field) {
  nlohmann::json e = {{"status", status}, {"message", message}};
  if (!field.empty()) e["field"] = field;
  SendJson(res, status, {{"error", e}});
}

void SendErrorAndClose(httplib::Response& res, int status, const std::string& message,
                       const std::string& field) {
  nlohmann::json e = {{"status", status}, {"message", message}};
  if (!field.empty()) e["field"] = field;
  auto body = std::make_shared<std::string>(JsonText({{"error", e}}, 2) + "\n");
  res.status = status;
  res.set_header("Connection", "close");
  res.set_content_provider(body->size(), "application/json",
                           [body](size_t offset, size_t length, httplib::DataSink& sink) {
                             sink.write(body->data() + offset, length);
                             return false;  // all written; "failing" closes the connection
                           });
}

bool RejectMalformedTarget(const httplib::Request& req, httplib::Response& res) {
  if (const int c = FirstControlByte(req.path); c >= 0) {
    char hex[16];
    std::snprintf(hex, sizeof hex, "0x%02x", unsigned(c));
    SendErrorAndClose(res, 400,
                      std::string("the request path contains the control byte ") + hex +
                          " (URL-encoded as %" + (hex + 2) +
                          "); paths never contain control characters");
    return true;
  }
  if (!IsUtf8(req.path)) {
    SendErrorAndClose(res, 400, "the request path '" + Printable(req.path) + "' is not UTF-8 text");
    return true;
  }
  for (const auto& [name, value] : req.params) {
    if (!IsUtf8(name)) {
      SendErrorAndClose(res, 400,
                        "query parameter name '" + Printable(name) + "' is not UTF-8 text",
                        Printable(name));
      return true;
    }
    if (!IsUtf8(value)) {
      SendErrorAndClose(
          res, 400,
          "query parameter '" + name + "' is not UTF-8 text (got '" + Printable(value) + "')",
          name);
      return true;
    }
  }
  return false;
}

const char* const kPageContentSecurityPolicy =
    "default-src 'self'; style-src 'self' 'unsafe-inline'; img-src 'self' data: blob:; "
    "object-src 'none'; base-uri 'none'; form-action 'self'; frame-ancestors 'self'";

void AddSecurityHeaders(httplib::Response& res) {
  res.set_header("X-Content-Type-Options", "nosniff");
  // Pages may carry ?token= (viewer links): never pass the URL on to another site.
  res.set_header("Referrer-Policy", "no-referrer");
  if (res.status >= 400) {  // an error is never cached (e.g. a preview on a full disk)
    res.headers.erase("Cache-Control");
    res.set_header("Cache-Control", "no-store");
  }
  if (res.get_header_value("Content-Type").rfind("text/html", 0) != 0)
    res.set_header("Content-Security-Policy",
                   "default-src 'none'; frame-ancestors 'none'; sandbox");
  else  // the embedded pages (landing page, viewer): their own scripts, styles and requests only
    res.set_header("Content-Security-Policy", kPageContentSecurityPolicy);
}

std::string PackFileType(const std::string& name) {
  const std::string ext = std::filesystem::path(name).extension().string();
  if (ext == ".json") return "application/json";
  if (ext == ".gltf") return "model/gltf+json";
  if (ext == ".png") return "image/png";
  if (ext == ".exr") return "image/x-exr";
  if (ext == ".jpg") return "image/jpeg";  // the relight web layout's planes
  return "application/octet-stream";       // .bin, and anything else
}

std::string ViewerFileType(const std::string& name) {
  const std::string ext = std::filesystem::path(name).extension().string();
  if (ext == ".html") return "text/html; charset=utf-8";
  if (ext == ".js") return "text/javascript; charset=utf-8";
  if (ext == ".glsl" || ext == ".frag" || ext == ".vert") return "text/plain; charset=utf-8";
  return "application/octet-stream";
}

void SendFile(httplib::Response& res, const std::string& path, const std::string& content_type) {
  std::error_code ec;
  const auto size = std::filesystem::file_size(path, ec);
  std::shared_ptr<FILE> f(ec ? nullptr : std::fopen(path.c_str(), "rb"), [](FILE* p) {
    if (p) std::fclose(p);
  });
  if (!f)
    return SendError(res, 404, "no file '" + std::filesystem::path(path).filename().string() + "'");
  res.status = 200;
  res.set_content_provider(size_t(size), content_type,
                           [f](size_t offset, size_t length, httplib::DataSink& sink) {
                             char buf[1 << 16];
                             const size_t n = std::min(length, sizeof buf);
                             if (std::fseek(f.get(), long(offset), SEEK_SET) != 0) return false;
                             const size_t got = std::fread(buf, 1, n, f.get());
                             return got > 0 && sink.write(buf, got);
                           });
}

std::string RouteOf(const std::string& path) {
  static const std::pair<const char*, const char*> kPrefixes[] = {
      {"/api/v1/viewer/static/", "/api/v1/viewer/static/{file}"},
      {"/api/v1/viewer/", "/api/v1/viewer/{id}"},
      {"/viewer/", "/viewer/{id}"},
  };
  for (const auto& [prefix, route] : kPrefixes)
    if (path.rfind(prefix, 0) == 0) return route;
  if (path == "/healthz" || path == "/metrics" || path == "/api/v1/healthz" ||
      path == "/api/v1/metrics" || path == "/api/v1/jobs")
    return path;
  const std::string jobs = "/api/v1/jobs/", packs = "/api/v1/packs/";
  if (path.rfind(jobs, 0) == 0) return "/api/v1/jobs/{id}";
  if (path.rfind(packs, 0) == 0) {
    const auto slash = path.find('/', packs.size());
    if (slash == std::string::npos) return "/api/v1/packs/{id}";
    const std::string rest = path.substr(slash);
    if (rest == "/preview.png" || rest == "/report") return "/api/v1/packs/{id}" + rest;
    return "/api/v1/packs/{id}/{file}";
  }
  return "other";
}

}  // namespace matfit::server
