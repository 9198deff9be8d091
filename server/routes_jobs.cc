// POST/GET/DELETE /api/v1/jobs: submission (multipart archive upload or a JSON body naming a
// dataset under an allow-listed root), status and cancellation.
#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <random>
#include <set>

#include "core/path_util.h"
#include "server/api_wording.h"
#include "server/archive.h"
#include "server/job_runner.h"
#include "server/job_spec.h"
#include "server/log.h"
#include "server/server_impl.h"
#include "server/text.h"

namespace matfit::server {
namespace {

namespace fs = std::filesystem;
using json = nlohmann::json;

std::string NewId() {
  static std::mutex m;
  static std::mt19937_64 rng(std::random_device{}() ^ (uint64_t(std::random_device{}()) << 32));
  std::lock_guard<std::mutex> lock(m);
  char b[17];
  std::snprintf(b, sizeof b, "%016llx", (unsigned long long)rng());
  return b;
}

std::string Iso(double t) {
  if (t <= 0) return "";
  const std::time_t s = std::time_t(t);
  std::tm tm{};
  gmtime_r(&s, &tm);
  char b[96];
  std::snprintf(b, sizeof b, "%04d-%02d-%02dT%02d:%02d:%02dZ", tm.tm_year + 1900, tm.tm_mon + 1,
                tm.tm_mday, tm.tm_hour, tm.tm_min, tm.tm_sec);
  return b;
}

json OrNull(const std::string& s) { return s.empty() ? json(nullptr) : json(s); }

constexpr int64_t kMaxFieldBytes = 4096;
constexpr int64_t kMaxJsonBody = 1 << 20;

// An upload in progress: everything lives under uploads/.partial-<id> until the job is queued.
struct Staging {
  std::string dir;
  bool keep = false;
  ~Staging() {
    std::error_code ec;
    if (!keep && !dir.empty()) fs::remove_all(dir, ec);
  }
};

}  // namespace

json Server::Impl::JobJson(const JobRecord& j) {
  const json spec = json::parse(j.spec_json, nullptr, false);
  double fraction = j.progress, started = j.started;
  std::string stage = j.stage;
  if (j.state == JobState::kRunning) {
    std::lock_guard<std::mutex> lock(mutex);
    if (auto it = live.find(j.id); it != live.end()) {
      std::lock_guard<std::mutex> l2(it->second->mutex);
      fraction = it->second->fraction, stage = it->second->stage;
    }
  }
  const double now = NowSeconds();
  json eta = nullptr;
  if (j.state == JobState::kRunning && fraction > 0.02 && started > 0)
    eta = std::round((now - started) * (1 - fraction) / fraction * 10) / 10;
  if (j.state == JobState::kSucceeded) eta = 0, fraction = 1, stage = "done";
  const std::string base = "/api/v1";
  json links = {{"self", base + "/jobs/" + j.id}};
  if (j.state == JobState::kSucceeded) {
    links["pack"] = base + "/packs/" + j.id;
    links["report"] = base + "/packs/" + j.id + "/report";
    links["preview"] = base + "/packs/" + j.id + "/preview.png";
    links["viewer"] = base + "/viewer/" + j.id;
    if (spec.value("mode", "fit") == "fit") {
      links["material"] = base + "/packs/" + j.id + "/material.json";
      links["gltf"] = base + "/packs/" + j.id + "/material.gltf";
    } else {
      links["leaves"] = base + "/packs/" + j.id + "/leaves.json";
    }
  }
  const double queued_s =
      (started > 0 ? started : (IsFinished(j.state) ? j.finished : now)) - j.created;
  json run_s = nullptr;
  if (IsFinished(j.state) && j.started > 0) run_s = j.run_seconds;
  if (j.state == JobState::kRunning) run_s = now - started;
  return {{"id", j.id},
          {"state", JobStateName(j.state)},
          {"mode", spec.value("mode", "fit")},
          {"options", spec},
          {"source", j.uploaded ? "upload" : j.dataset},
          {"created", Iso(j.created)},
          {"started", OrNull(Iso(j.started))},
          {"finished", OrNull(Iso(j.finished))},
          {"progress", {{"fraction", fraction}, {"stage", stage}, {"eta_seconds", eta}}},
          {"timings", {{"queued_seconds", std::max(0.0, queued_s)}, {"run_seconds", run_s}}},
          {"attempts", j.attempts},
          {"node", OrNull(j.node)},
          {"cancel_requested", j.cancel_requested},
          {"error", OrNull(j.error)},
          {"summary", json::parse(j.summary_json, nullptr, false)},
          {"links", links}};
}

void Server::Impl::RemoveJobFiles(const JobRecord& j) {
  std::error_code ec;
  if (j.uploaded) fs::remove_all(DatasetsDir() + "/" + j.id, ec);
  fs::remove_all(PackDir(j.id), ec);
  fs::remove(ZipPath(j.id), ec);
  fs::remove_all(PreviewDir(j.id), ec);
  preview_cache->ForgetJob(j.id);
}

void Server::Impl::RegisterJobRoutes() {
  http.Post("/api/v1/jobs", [this](const httplib::Request& req, httplib::Response& res,
                                   const httplib::ContentReader& reader) {
    if (draining) return SendErrorAndClose(res, 503, "the server is shutting down; retry shortly");
    const std::string id = NewId();
    JobRecord job;
    job.id = id;
    job.created = NowSeconds();
    StatusOr<JobSpec> spec = InvalidArgument("no options");
    Staging staging;
    if (req.is_multipart_form_data()) {
      staging.dir = UploadsDir() + "/.partial-" + id;
      std::error_code ec;
      fs::create_directories(staging.dir, ec);
      const std::string upload = staging.dir + "/upload.bin";
      std::map<std::string, std::string> fields;
      std::string current, problem_field;
      std::unique_ptr<FILE, int (*)(FILE*)> out(nullptr, std::fclose);
      bool has_file = false, too_big = false, write_failed = false, unknown = false,
           not_utf8 = false;
      int64_t bytes = 0;
      const bool ok = reader(
          [&](const httplib::MultipartFormData& part) {
            current = part.name;
            if (!IsUtf8(current)) return problem_field = current, not_utf8 = true, false;
            static const std::set<std::string> kFields = {
                "file", "model", "view", "mode", "holdout", "budget", "layout", "color_space"};
            if (!kFields.count(current)) return problem_field = current, unknown = true, false;
            if (current == "file") {
              if (has_file) return problem_field = "file", false;
              has_file = true;
              out.reset(std::fopen(upload.c_str(), "wb"));
              if (!out) return write_failed = true, false;
            } else if (fields.count(current)) {
              return problem_field = current, false;
            } else {
              fields[current];
            }
            return true;
          },
          [&](const char* data, size_t n) {
            if (current == "file") {
              bytes += int64_t(n);
              if (bytes > options.max_upload_bytes) return too_big = true, false;
              if (std::fwrite(data, 1, n, out.get()) != n) return write_failed = true, false;
              return true;
            }
            std::string& v = fields[current];
            if (int64_t(v.size() + n) > kMaxFieldBytes) return problem_field = current, false;
            bytes += int64_t(n);  // every byte counts toward the limit (chunked bodies too)
            if (bytes > options.max_upload_bytes) return too_big = true, false;
            v.append(data, n);
            return true;
          });
      if (out && std::fclose(out.release()) != 0) write_failed = true;
      metrics.ObserveUpload(bytes);
      if (too_big || res.status == 413)
        return SendErrorAndClose(res, 413,
                                 "the upload is larger than the server's limit of " +
                                     std::to_string(options.max_upload_bytes >> 20) + " MiB",
                                 "file");
      if (write_failed) return SendErrorAndClose(res, 507, "the server could not store the upload");
      if (not_utf8)
        return SendErrorAndClose(res, 400,
                                 "form field name '" + Printable(problem_field) +
                                     "' is not UTF-8 text; use file, model, view, mode, holdout, "
                                     "budget",
                                 Printable(problem_field));
      if (unknown)
        return SendErrorAndClose(
            res, 400,
            "form field '" + Printable(problem_field) +
                "' is not an option; use file, model, view, mode, holdout, budget",
            Printable(problem_field));
      if (!problem_field.empty())
        return SendErrorAndClose(
            res, 400, "form field '" + problem_field + "' is repeated or longer than 4 KiB",
            problem_field);
      if (!ok)
        return SendErrorAndClose(res, 400, "the multipart upload is malformed or was interrupted");
      if (!has_file)
        return SendErrorAndClose(
            res, 400,
            "form field 'file' (the dataset archive: .zip, .tar or .tar.gz) is "
            "required",
            "file");
      // Values end up in the job record and in messages (JSON): UTF-8 only.
      for (const auto& [name, value] : fields)
        if (!IsUtf8(value))
          return SendErrorAndClose(res, 400,
                                   "form field '" + name + "' is not UTF-8 text (got '" +
                                       Printable(value) + "'); send it as UTF-8",
                                   name);
      spec = ParseJobSpecFields(fields);
      if (!spec.ok())
        return SendErrorAndClose(res, 400, spec.status().message(),
                                 FieldOfError(spec.status().message()));
      ArchiveProblem problem;
      auto ex = ExtractArchive(upload, staging.dir + "/dataset", options.archive, &problem);
      fs::remove(upload, ec);
      if (!ex.ok())
        return SendErrorAndClose(res,
                                 problem == ArchiveProblem::kLimit     ? 413
                                 : problem == ArchiveProblem::kNoSpace ? 507
                                 : problem == ArchiveProblem::kNone    ? 500
                                                                       : 400,
                                 ForClients(ex.status().message()), "file");
      std::string field;
      if (Status st = ValidateDataset(*spec, ex->dataset_root, options.max_stack_samples, &field);
          !st.ok()) {
        JobRecord unpacked;  // the reader's paths, relative to the archive's dataset folder
        unpacked.dataset = ex->dataset_root, unpacked.uploaded = true;
        LogEvent("info", "upload_refused", {{"id", id}, {"reason", st.message()}});
        return SendErrorAndClose(res, 422, ForClients(st.message(), &unpacked),
                                 field.empty() ? "file" : field);
      }
      // Move into place; the dataset path keeps the archive's top folder, if any.
      const std::string rel = fs::relative(ex->dataset_root, staging.dir + "/dataset", ec).string();
      const std::string final_dir = DatasetsDir() + "/" + id;
      fs::rename(staging.dir + "/dataset", final_dir, ec);
      if (ec)
        return SendErrorAndClose(res, 500, "cannot move the upload into place: " + ec.message());
      job.dataset = rel == "." ? final_dir : final_dir + "/" + rel;
      job.uploaded = true;
    } else {
      const std::string type = req.get_header_value("Content-Type");
      if (type.rfind("application/json", 0) != 0)
        return SendErrorAndClose(res, 415,
                                 "POST /api/v1/jobs takes multipart/form-data (an archive in field "
                                 "'file') or application/json ({\"dataset\": ...}), got '" +
                                     Printable(type) + "'");
      std::string body;
      bool too_big = false;
      const bool ok = reader([&](const char* data, size_t n) {
        if (int64_t(body.size() + n) > kMaxJsonBody) return too_big = true, false;
        body.append(data, n);
        return true;
      });
      if (too_big) return SendErrorAndClose(res, 413, "the JSON body is larger than 1 MiB");
      if (!ok) return SendErrorAndClose(res, 400, "the request body could not be read");
      std::string dataset;
      spec = ParseJobSpecJson(body, &dataset);
      if (!spec.ok())
        return SendErrorAndClose(res, 400, spec.status().message(),
                                 FieldOfError(spec.status().message()));
      if (options.allow_roots.empty())
        return SendErrorAndClose(res, 403,
                                 "this server accepts no dataset paths (start it with --allow-root "
                                 "DIR); upload an archive instead",
                                 "dataset");
      std::error_code ec;
      const std::string canonical = fs::weakly_canonical(fs::absolute(dataset, ec), ec).string();
      bool allowed = false;
      for (const auto& root : options.allow_roots) allowed = allowed || PathWithin(canonical, root);
      if (!allowed)
        return SendErrorAndClose(
            res, 403, "dataset '" + dataset + "' is not inside an allowed root (--allow-root)",
            "dataset");
      // 404 for a folder that is not there; a folder whose contents fail the check is 422.
      const bool exists = fs::is_directory(canonical, ec);
      std::string field;
      if (Status st = ValidateDataset(*spec, canonical, options.max_stack_samples, &field);
          !st.ok())
        return SendErrorAndClose(res, exists ? 422 : 404, ApiWording(st.message()),
                                 field.empty() ? "dataset" : field);
      job.dataset = canonical;
    }
    job.spec_json = JsonText(spec->ToJson());
    if (Status st = store->Insert(&job); !st.ok()) {
      if (job.uploaded) {
        std::error_code ec;
        fs::remove_all(DatasetsDir() + "/" + id, ec);
      }
      return SendErrorAndClose(res, 500, st.message());
    }
    wake.notify_one();
    LogEvent("info", "job_queued",
             {{"id", id}, {"spec", spec->ToJson()}, {"uploaded", job.uploaded}});
    res.set_header("Location", "/api/v1/jobs/" + id);
    SendJson(res, 202, {{"id", id}, {"state", "queued"}, {"links", JobJson(job)["links"]}});
  });

  http.Get("/api/v1/jobs", [this](const httplib::Request& req, httplib::Response& res) {
    std::optional<JobState> state;
    if (req.has_param("state")) {
      JobState s;
      if (!ParseJobState(req.get_param_value("state"), &s))
        return SendError(res, 400,
                         "query 'state' must be queued, running, succeeded, failed or cancelled",
                         "state");
      state = s;
    }
    int limit = 100;
    if (req.has_param("limit")) {
      const std::string v = req.get_param_value("limit");
      char* end = nullptr;
      const long l = std::strtol(v.c_str(), &end, 10);
      if (v.empty() || *end || l < 1 || l > 1000)
        return SendError(res, 400, "query 'limit' must be in [1, 1000]", "limit");
      limit = int(l);
    }
    // Final states the database has not taken yet count as what they are.
    std::vector<JobRecord> list = store->List(state, limit);
    std::vector<std::string> pending_ids;
    {
      std::lock_guard<std::mutex> lock(pending_mutex);
      for (const auto& [id, f] : pending)
        if (!state || f.final_state.state == *state) pending_ids.push_back(id);
    }
    for (auto& j : list) ApplyPending(&j);
    std::erase_if(list, [&](const JobRecord& j) { return state && j.state != *state; });
    for (const auto& id : pending_ids)
      if (std::none_of(list.begin(), list.end(), [&](const JobRecord& j) { return j.id == id; }))
        if (auto j = GetJob(id); j && (!state || j->state == *state)) list.push_back(*j);
    std::sort(list.begin(), list.end(),
              [](const JobRecord& a, const JobRecord& b) { return a.seq > b.seq; });
    if (int(list.size()) > limit) list.resize(size_t(limit));
    json jobs = json::array();
    for (const auto& j : list) jobs.push_back(JobJson(j));
    SendJson(res, 200, {{"jobs", jobs}});
  });

  http.Get(R"(/api/v1/jobs/([^/]+))", [this](const httplib::Request& req, httplib::Response& res) {
    const auto j = GetJob(req.matches[1]);
    if (!j) return SendError(res, 404, "no job '" + std::string(req.matches[1]) + "'");
    SendJson(res, 200, JobJson(*j));
  });

  http.Delete(R"(/api/v1/jobs/([^/]+))", [this](const httplib::Request& req,
                                                httplib::Response& res) {
    const std::string id = req.matches[1];
    auto j = GetJob(id);
    if (!j) return SendError(res, 404, "no job '" + id + "'");
    const auto unsaved = [&](const Status& st) {
      return SendError(res, 507,
                       "job '" + id + "' is " + JobStateName(j->state) +
                           ", but the job database cannot record the change (" +
                           ForClients(st.message()) +
                           "); free space in the server's data folder and retry");
    };
    if (!IsFinished(j->state)) {
      Status write_error;
      const bool asked = store->RequestCancel(id, NowSeconds(), &write_error);
      bool running_here = false;
      {
        std::lock_guard<std::mutex> lock(mutex);
        if (auto it = live.find(id); it != live.end())
          it->second->cancel = true, running_here = true;
      }
      LogEvent("info", "job_cancel", {{"id", id}, {"was", JobStateName(j->state)}});
      // A worker running it sees the flag; otherwise the database must have it.
      if (!running_here && !write_error.ok()) return unsaved(write_error);
      j = GetJob(id);
      if (!j) return SendError(res, 404, "no job '" + id + "'");  // deleted meanwhile
      if (j->state == JobState::kCancelled) return SendJson(res, 200, JobJson(*j));
      // 202 only when someone will act on the cancel: a worker running the job
      // here, or the flag stored for the worker that claimed it.
      if (!IsFinished(j->state) && (running_here || asked)) return SendJson(res, 202, JobJson(*j));
      if (!IsFinished(j->state))
        return SendError(
            res, 409,
            "job '" + id + "' is " + JobStateName(j->state) + " and could not be cancelled; retry");
      // It finished meanwhile: delete it as below.
    }
    // A final state only in memory must reach the database before the row goes.
    if (Status st = RetryPending(false, id); !st.ok()) return unsaved(st);
    // Only a finished job is deleted, and once: a concurrent DELETE gets 404.
    Status write_error;
    if (!store->DeleteFinished(id, &write_error))
      return write_error.ok() ? SendError(res, 404, "no job '" + id + "'") : unsaved(write_error);
    RemoveJobFiles(*j);
    LogEvent("info", "job_deleted", {{"id", id}});
    res.status = 204;
  });
}

}  // namespace matfit::server
