#include "capture/session.h"

#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>

#include "capture/sim/sim_devices.h"
#include "core/atomic_file.h"
#include "core/image_io.h"

namespace matfit::capture {
namespace {

namespace fs = std::filesystem;
using json = nlohmann::json;

std::string Name(int k) {
  char b[32];
  std::snprintf(b, sizeof b, "img_%03d.exr", k);
  return b;
}

json PlanJson(const CapturePlan& p) {
  json j = {{"leds", p.leds},
            {"exposures_s", p.exposures_s},
            {"gain", p.gain},
            {"repeats", p.repeats},
            {"dark_frames", p.dark_frames},
            {"level", p.level},
            {"flat_field", p.flat_field},
            {"timeout_ms", p.timeout_ms},
            {"hdr_range", {p.hdr.low, p.hdr.high}}};
  if (p.has_format)
    j["format"] = {{"pixel_format", PixelFormatName(p.format.pixel_format)},
                   {"width", p.format.width},
                   {"height", p.format.height}};
  return j;
}

// The mean of `repeats` frames at the current settings.
StatusOr<Image> Average(Camera& cam, int repeats, int timeout_ms) {
  Image sum;
  for (int r = 0; r < repeats; ++r) {
    auto f = cam.Grab(timeout_ms);
    if (!f.ok()) return f.status();
    if (r == 0) {
      sum = std::move(*f);
      continue;
    }
    for (size_t i = 0; i < sum.data().size(); ++i) sum.data()[i] += f->data()[i];
  }
  for (float& v : sum.data()) v /= float(repeats);
  return sum;
}

// Dark frames at every exposure of the bracket (all LEDs off).
StatusOr<std::vector<Image>> Darks(Camera& cam, LightRig& rig, const CapturePlan& p) {
  std::vector<Image> darks;
  if (p.dark_frames == 0) return darks;
  MATFIT_RETURN_IF_ERROR(rig.AllOff());
  for (double t : p.exposures_s) {
    MATFIT_RETURN_IF_ERROR(cam.SetExposure(t));
    auto d = Average(cam, p.dark_frames, p.timeout_ms);
    if (!d.ok()) return d.status();
    darks.push_back(std::move(*d));
  }
  return darks;
}

// The HDR radiance of whatever the rig lights now.
StatusOr<Image> Bracketed(Camera& cam, const CapturePlan& p, const std::vector<Image>& darks,
                          int64_t* saturated) {
  std::vector<Image> frames;
  for (double t : p.exposures_s) {
    MATFIT_RETURN_IF_ERROR(cam.SetExposure(t));
    auto f = Average(cam, p.repeats, p.timeout_ms);
    if (!f.ok()) return f.status();
    frames.push_back(std::move(*f));
  }
  std::vector<Bracket> b;
  for (size_t i = 0; i < frames.size(); ++i)
    b.push_back({&frames[i], darks.empty() ? nullptr : &darks[i], p.exposures_s[i]});
  return MergeBrackets(b, p.hdr, saturated);
}

Status Setup(Camera& cam, LightRig& rig, const CapturePlan& p) {
  cam.AttachLightRig(&rig);
  if (p.has_format) MATFIT_RETURN_IF_ERROR(cam.SetFormat(p.format));
  if (p.gain != 1 || cam.Info().gain) MATFIT_RETURN_IF_ERROR(cam.SetGain(p.gain));
  for (int led : p.leds)
    if (led < 0 || led >= rig.Count())
      return InvalidArgument("plan '" + p.source + "': LED " + std::to_string(led) +
                             " does not exist; the rig has " + std::to_string(rig.Count()));
  return Status::Ok();
}

ImageWriteOptions Exr() {
  ImageWriteOptions o;
  o.format = ::matfit::PixelFormat::kFloat;
  o.transfer = TransferFunction::kLinear;
  return o;
}

}  // namespace

bool CapturePlan::Check(std::string* why) const {
  auto fail = [&](const std::string& m) { return *why = "plan '" + source + "': " + m, false; };
  if (exposures_s.empty()) return fail("'exposures_s' needs at least one exposure");
  for (double t : exposures_s) {
    if (!(t > 0 && t <= 3600)) return fail("every exposure must be in (0, 3600] s");
    if (t * 1000 >= timeout_ms)
      return fail("exposure " + std::to_string(t) + " s is longer than 'timeout_ms' (" +
                  std::to_string(timeout_ms) + " ms); raise the timeout");
  }
  if (!(gain >= 1 && gain <= 16)) return fail("'gain' must be in [1, 16]");
  if (repeats < 1 || repeats > 1000) return fail("'repeats' must be in [1, 1000]");
  if (dark_frames < 0 || dark_frames > 1000) return fail("'dark_frames' must be in [0, 1000]");
  if (!(level > 0 && level <= 1)) return fail("'level' must be in (0, 1]");
  if (timeout_ms < 1) return fail("'timeout_ms' must be ≥ 1");
  if (!(hdr.low >= 0 && hdr.low < hdr.high && hdr.high <= 1))
    return fail("'hdr_range' must be 0 ≤ low < high ≤ 1");
  return true;
}

StatusOr<CapturePlan> ReadPlan(const std::string& path) {
  std::ifstream in(path);
  if (!in) return NotFound("cannot open capture plan '" + path + "'");
  std::stringstream text;
  text << in.rdbuf();
  json j;
  try {
    j = json::parse(text.str());
  } catch (const json::exception& e) {  // parse_error, or out_of_range (a number like 1e999)
    return DataError("capture plan '" + path + "' is not valid JSON: " + e.what());
  }
  CapturePlan p;
  p.source = path;
  auto bad = [&](const std::string& f, const std::string& why) {
    return DataError("capture plan '" + path + "': field '" + f + "' " + why);
  };
  if (!j.is_object()) return DataError("capture plan '" + path + "' must be a JSON object");
  static const std::set<std::string> kFields = {
      "schema", "leds",       "exposures_s", "gain",       "repeats",  "dark_frames",
      "level",  "flat_field", "format",      "timeout_ms", "hdr_range"};
  for (const auto& [k, v] : j.items())
    if (!kFields.count(k)) return bad(k, "is not a plan field (see docs/capture.md)");
  if (j.contains("schema") && j["schema"] != "matfit.captureplan/1")
    return bad("schema", "must be \"matfit.captureplan/1\"");
  if (j.contains("leds")) {
    if (j["leds"].is_string() && j["leds"] == "all") {
    } else if (j["leds"].is_array()) {
      for (const auto& v : j["leds"]) {
        if (!v.is_number_integer() || v.get<int64_t>() < 0 || v.get<int64_t>() > 65535)
          return bad("leds", "must list LED indices (integers in [0, 65535])");
        p.leds.push_back(int(v.get<int64_t>()));
      }
      if (p.leds.empty()) return bad("leds", "lists no LED; give indices or \"all\"");
    } else {
      return bad("leds", "must be \"all\" or a list of LED indices");
    }
  }
  if (!j.contains("exposures_s") || !j["exposures_s"].is_array())
    return bad("exposures_s", "is required: a list of exposures in seconds");
  for (const auto& v : j["exposures_s"]) {
    if (!v.is_number()) return bad("exposures_s", "must list numbers (seconds)");
    p.exposures_s.push_back(v.get<double>());
  }
  auto number = [&](const char* f, double* out) -> Status {
    if (!j.contains(f)) return Status::Ok();
    if (!j[f].is_number()) return bad(f, "must be a number");
    *out = j[f].get<double>();
    return Status::Ok();
  };
  auto integer = [&](const char* f, int64_t lo, int64_t hi, int* out) -> Status {
    if (!j.contains(f)) return Status::Ok();
    if (!j[f].is_number_integer() || j[f].get<int64_t>() < lo || j[f].get<int64_t>() > hi)
      return bad(f,
                 "must be an integer in [" + std::to_string(lo) + ", " + std::to_string(hi) + "]");
    *out = int(j[f].get<int64_t>());
    return Status::Ok();
  };
  MATFIT_RETURN_IF_ERROR(number("gain", &p.gain));
  MATFIT_RETURN_IF_ERROR(integer("repeats", 1, 1000, &p.repeats));
  MATFIT_RETURN_IF_ERROR(integer("dark_frames", 0, 1000, &p.dark_frames));
  MATFIT_RETURN_IF_ERROR(number("level", &p.level));
  MATFIT_RETURN_IF_ERROR(integer("timeout_ms", 1, 3600000, &p.timeout_ms));
  if (j.contains("hdr_range")) {
    const json& r = j["hdr_range"];
    if (!r.is_array() || r.size() != 2 || !r[0].is_number() || !r[1].is_number())
      return bad("hdr_range", "must be [low, high] in full-scale units");
    p.hdr.low = r[0].get<double>(), p.hdr.high = r[1].get<double>();
  }
  if (j.contains("flat_field")) {
    if (!j["flat_field"].is_string()) return bad("flat_field", "must be a file name");
    fs::path f = j["flat_field"].get<std::string>();
    if (f.is_relative()) f = fs::path(path).parent_path() / f;
    p.flat_field = f.string();
  }
  if (j.contains("format")) {
    const json& f = j["format"];
    if (!f.is_object() || !f.contains("pixel_format") || !f["pixel_format"].is_string() ||
        !ParsePixelFormat(f["pixel_format"].get<std::string>(), &p.format.pixel_format))
      return bad("format", "needs pixel_format YUYV, MJPEG, GREY, Y16 or RGB24");
    const json w = f.value("width", json(0)), h = f.value("height", json(0));
    if (!w.is_number_integer() || !h.is_number_integer() || w.get<int64_t>() < 1 ||
        h.get<int64_t>() < 1 || w.get<int64_t>() > 65536 || h.get<int64_t>() > 65536)
      return bad("format", "needs integer width and height in [1, 65536]");
    p.format.width = int(w.get<int64_t>()), p.format.height = int(h.get<int64_t>());
    p.has_format = true;
  }
  std::string why;
  if (!p.Check(&why)) return DataError(why);
  return p;
}

StatusOr<CaptureResult> RunCapture(Camera& cam, LightRig& rig, const CapturePlan& plan,
                                   const std::string& out, bool overwrite,
                                   const CaptureProgress& progress) {
  std::string why;
  if (!plan.Check(&why)) return InvalidArgument(why);
  MATFIT_RETURN_IF_ERROR(Setup(cam, rig, plan));
  std::vector<int> leds = plan.leds;
  if (leds.empty())
    for (int i = 0; i < rig.Count(); ++i) leds.push_back(i);
  const json plan_json = PlanJson(plan);
  const std::string camera_uri = cam.Info().uri, rig_name = rig.Describe();
  std::error_code ec;
  const fs::path dir(out), record_path = dir / "capture.json";

  // The flat field is read before anything in `out` changes (it may live there).
  Image flat;
  if (!plan.flat_field.empty()) {
    ImageReadOptions ro;
    ro.color_space = ColorSpaceChoice::kLinear;
    auto f = ReadImage(plan.flat_field, ro);
    if (!f.ok()) return f.status();
    if (f->width() != cam.Format().width || f->height() != cam.Format().height)
      return InvalidArgument("flat field '" + plan.flat_field + "' is " +
                             std::to_string(f->width()) + "x" + std::to_string(f->height()) +
                             " but the camera delivers " + std::to_string(cam.Format().width) +
                             "x" + std::to_string(cam.Format().height));
    flat = NormaliseFlat(*f);
  }

  // Resume: same plan and devices, images already written are kept.
  json record;
  const bool have_record = fs::exists(record_path, ec);
  if (have_record) {
    std::ifstream in(record_path);
    record = json::parse(in, nullptr, false);
    if (!record.is_object() || !record.contains("images") || !record["images"].is_array())
      return DataError("'" + record_path.string() +
                       "' is not a capture record; move it away or choose another --out");
  }
  if (have_record && !overwrite) {
    if (record.value("plan", json()) != plan_json ||
        record.value("camera", json()) != json(camera_uri) ||
        record.value("rig", json()) != json(rig_name))
      return InvalidArgument("'" + out +
                             "' holds a capture with another plan or other devices; choose "
                             "another --out or pass --force to start again");
    if (record.value("complete", json(false)) == json(true))
      return InvalidArgument("'" + out + "' holds a finished capture; pass --force to redo it");
  } else {
    if (fs::exists(dir, ec) && !fs::is_empty(dir, ec) && !have_record)
      return InvalidArgument("'" + out +
                             "' exists and is not a capture (no capture.json); choose another "
                             "--out" +
                             (overwrite ? " (--force only replaces captures)" : ""));
    if (have_record) {  // --force on a capture: remove what a capture writes, nothing else
      for (const auto& e : fs::directory_iterator(dir, ec)) {
        const std::string n = e.path().filename().string();
        if ((n.rfind("img_", 0) == 0 && e.path().extension() == ".exr") || n == "lights.lp" ||
            n == "capture.json" || n == "truth")
          fs::remove_all(e.path(), ec);
      }
    }
    fs::create_directories(dir, ec);
    if (ec) return IoError("cannot create '" + out + "': " + ec.message());
    record = {{"schema", "matfit.capture/1"},
              {"plan", plan_json},
              {"camera", camera_uri},
              {"rig", rig_name},
              {"complete", false},
              {"images", json::array()}};
  }
  const CameraInfo info = cam.Info();
  record["camera_info"] = {{"driver", info.driver},
                           {"name", info.name},
                           {"format",
                            {{"pixel_format", PixelFormatName(cam.Format().pixel_format)},
                             {"width", cam.Format().width},
                             {"height", cam.Format().height}}}};
  auto save = [&] {
    return WriteFileAtomic(record_path.string(),
                           record.dump(2, ' ', false, json::error_handler_t::replace) + "\n");
  };
  // Images recorded and present are done; records of missing files are dropped (recaptured).
  std::map<int, bool> done;
  json kept = json::array();
  for (const auto& im : record["images"]) {
    if (!im.is_object() || !im.contains("index") || !im["index"].is_number_integer() ||
        !im.contains("file") || !im["file"].is_string())
      continue;
    if (fs::exists(dir / im["file"].get<std::string>(), ec)) {
      done[im["index"].get<int>()] = true;
      kept.push_back(im);
    }
  }
  record["images"] = kept;

  auto darks = Darks(cam, rig, plan);
  if (!darks.ok()) return darks.status();
  CaptureResult result;
  result.out = out;
  for (size_t k = 0; k < leds.size(); ++k) {
    if (done.count(int(k))) {
      result.resumed++;
      continue;
    }
    MATFIT_RETURN_IF_ERROR(rig.AllOff());
    MATFIT_RETURN_IF_ERROR(rig.Set(leds[k], plan.level));
    int64_t sat = 0;
    auto img = Bracketed(cam, plan, *darks, &sat);
    if (!img.ok()) {
      (void)rig.AllOff();
      return Status(img.status().code(), img.status().message() + " (at image " +
                                             std::to_string(k) +
                                             "; run the same command again "
                                             "to resume)");
    }
    if (!flat.empty()) ApplyFlatField(flat, &*img);
    // The .lp readers take intensities as nominal: divide out the LED level.
    for (float& v : img->data()) v = float(v / plan.level);
    MATFIT_RETURN_IF_ERROR(WriteImage((dir / Name(int(k))).string(), *img, Exr()));
    const Vec3 d = rig.Direction(leds[k]);
    record["images"].push_back(
        {{"index", k},
         {"file", Name(int(k))},
         {"led", leds[k]},
         {"direction", {d.x, d.y, d.z}},
         {"saturated_pixels", sat},
         {"unix_time",
          std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch())
              .count()}});
    MATFIT_RETURN_IF_ERROR(save());
    result.images++;
    result.saturated_pixels += sat;
    if (progress && !progress(int(k + 1), int(leds.size()))) {
      (void)rig.AllOff();
      return Status(StatusCode::kCancelled, "capture stopped after image " + std::to_string(k) +
                                                "; run the same command again to resume");
    }
  }
  MATFIT_RETURN_IF_ERROR(rig.AllOff());
  // The light file last: a dataset is readable only when complete.
  std::string lp = std::to_string(leds.size()) + "\n";
  for (size_t k = 0; k < leds.size(); ++k) {
    const Vec3 d = rig.Direction(leds[k]);
    char line[160];
    std::snprintf(line, sizeof line, "%s %.9f %.9f %.9f\n", Name(int(k)).c_str(), d.x, d.y, d.z);
    lp += line;
  }
  MATFIT_RETURN_IF_ERROR(WriteFileAtomic((dir / "lights.lp").string(), lp));
  MaterialMaps truth;
  if (SimCameraTruth(cam, !flat.empty(), &truth)) {  // simulated: ground truth for scoring
    const fs::path t = dir / "truth";
    fs::create_directories(t, ec);
    MATFIT_RETURN_IF_ERROR(WriteImage((t / "normal.exr").string(), truth.normal, Exr()));
    MATFIT_RETURN_IF_ERROR(WriteImage((t / "albedo.exr").string(), truth.albedo, Exr()));
    ImageWriteOptions png;
    png.format = ::matfit::PixelFormat::kUint8;
    MATFIT_RETURN_IF_ERROR(WriteImage((t / "mask.png").string(), truth.mask, png));
    const json params = {{"schema", "matfit.truth/1"},
                         {"source", "matfit capture with " + camera_uri},
                         {"model", {{"name", ShadingModelName(truth.model)}}},
                         {"note",
                          "albedo in the capture's units (sensor sensitivity, vignetting "
                          "or its mean when flat-fielded)"}};
    MATFIT_RETURN_IF_ERROR(WriteFileAtomic((t / "params.json").string(), params.dump(2) + "\n"));
  }
  record["complete"] = true;
  MATFIT_RETURN_IF_ERROR(save());
  return result;
}

Status CaptureFlatField(Camera& cam, LightRig& rig, const CapturePlan& plan,
                        const std::string& out) {
  std::string why;
  if (!plan.Check(&why)) return InvalidArgument(why);
  MATFIT_RETURN_IF_ERROR(Setup(cam, rig, plan));
  auto darks = Darks(cam, rig, plan);
  if (!darks.ok()) return darks.status();
  MATFIT_RETURN_IF_ERROR(rig.All(plan.level));
  int64_t sat = 0;
  auto img = Bracketed(cam, plan, *darks, &sat);
  (void)rig.AllOff();
  if (!img.ok()) return img.status();
  if (sat > img->plane_size() / 100)
    return DataError("the flat-field target saturates at every exposure in " + std::to_string(sat) +
                     " pixels; add a shorter exposure");
  return WriteImage(out, NormaliseFlat(*img), Exr());
}

}  // namespace matfit::capture
