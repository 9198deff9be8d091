#include "fit/stream_fit.h"

#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>

#include "core/parallel.h"
#include "fit/fit_common.h"
#include "fit/methods.h"
#include "fit/score.h"

namespace matfit::fit {

StatusOr<StreamedFit> StreamedFit::Open(const std::string& input, const ReadOptions& read) {
  StreamedFit f;
  f.input_ = input;
  f.read_ = read;
  f.read_.progress = {};
  ReadOptions headers = f.read_;
  headers.headers_only = true;
  auto shape = ReadDataset(input, headers);
  if (!shape.ok()) return shape.status();
  f.shape_ = std::move(*shape);
  return f;
}

int64_t StreamedFit::FloatBytes() const {
  return int64_t(shape_.lights().size()) * shape_.plane_size() * shape_.channels() * 4;
}

namespace {

// The process's resident memory now (bytes; 0 when /proc is unreadable).
int64_t ResidentBytes() {
  std::FILE* f = std::fopen("/proc/self/statm", "r");
  if (!f) return 0;
  long pages = 0, resident = 0;
  const int got = std::fscanf(f, "%ld %ld", &pages, &resident);
  std::fclose(f);
  return got == 2 ? int64_t(resident) * ::sysconf(_SC_PAGESIZE) : 0;
}

}  // namespace

Status StreamedFit::BuildCache(const StreamFitOptions& o, const ProgressFn& progress) {
  // What the budget must also hold besides a band (or a decode chunk, never both): the process
  // as it is, each thread's samples of a run of texels (svbrdf_fit.cc: 16 texels × images ×
  // channels doubles), and the maps and per-texel planes (≈ 64 bytes a texel, twice: the start's
  // and the result's), and an eighth of the budget for the rest (the frontal view, truth, the
  // pack writer). A band gets half of what is left (the allocator keeps freed blocks), a quarter
  // with held-out views (the band and its training views' copy: with a third, 2-thread runs of
  // the CLI test's 48 MB budget peaked anywhere in 43.7–54.8 MB, with a quarter in 41.2–46.0).
  const int64_t n = int64_t(shape_.lights().size()), C = shape_.channels();
  const int64_t reserve = ResidentBytes() + int64_t(NumThreads()) * 16 * n * C * 8 +
                          2 * 64 * shape_.plane_size() + o.memory_bytes / 8;  // + the unforeseen
  BandCacheOptions co;
  co.band_bytes = std::max<int64_t>(1, (o.memory_bytes - reserve) / (o.holdout_views ? 4 : 2));
  co.dir = o.cache_dir;
  co.progress = progress;
  band_bytes_ = co.band_bytes;
  auto cache = BandCache::Build(shape_, read_, co);
  if (!cache.ok()) return cache.status();
  cache_ = std::make_unique<BandCache>(std::move(*cache));
  return Status::Ok();
}

Status StreamedFit::FitStart(const FitOptions& o) {
  const auto groups = ViewGroups(shape_);
  const LightSample& front =
      shape_.lights()[size_t(groups[size_t(MostFrontalView(shape_, groups))][0])];
  ReadOptions one = read_;
  one.all_views = false;
  one.view = ViewAngles{front.view_theta_deg, front.view_phi_deg};
  auto stack = ReadDataset(input_, one);
  if (!stack.ok()) return stack.status();
  if (cache_ && !cache_->mask().empty()) {  // the mask of every view, as an in-memory read has
    stack->mask = cache_->mask();
    stack->mask_source = cache_->meta().mask_source;
  }
  if (read_.color_space == ColorSpaceChoice::kAuto) {
    StackDiagnostics diagnosis = DiagnoseStack(*stack);
    tone_ = ResolveToneCurve(&*stack, &diagnosis);
    if (tone_->corrected && !stack->encoding_reasons.empty())
      tone_reason_ = stack->encoding_reasons[0];
  }
  auto start = SvbrdfStart(*stack, o);
  if (!start.ok()) return start.status();
  start_ = std::move(*start);
  return Status::Ok();
}

Status StreamedFit::FitBands(const FitOptions& o, const ProgressFn& progress,
                             const std::vector<int>& held) {
  if (!cache_ || !start_)
    return InvalidArgument("StreamedFit: build the cache and the start first");
  const int W = shape_.width(), H = shape_.height();
  FitResult& r = result_;
  r = FitResult();
  r.method = "svbrdf";
  r.maps = start_->maps;  // model, size, mask; every texel map is overwritten band by band
  r.maps.specular = Image(W, H, 1), r.maps.roughness = Image(W, H, 1);
  r.status.assign(size_t(W) * H, 0);
  double sse = 0, samples = 0, sse_common = 0, samples_common = 0;
  double iterations = 0, used = 0, fitted = 0;
  const int bands = cache_->bands();
  // Held-out views: the training images, and each held-out view's images by θl group.
  const auto groups = ViewGroups(shape_);
  for (int h : held)
    if (h < 0 || h >= int(groups.size()) || h == MostFrontalView(shape_, groups))
      return InvalidArgument("held-out view " + std::to_string(h) + " is not one of the " +
                             std::to_string(groups.size()) +
                             " views other than the most frontal (svbrdf starts from it)");
  std::vector<int> train;
  std::vector<std::map<int, std::vector<int>>> tests(held.size());
  {
    std::vector<char> out(groups.size(), 0);
    for (size_t h = 0; h < held.size(); ++h) {
      out[size_t(held[h])] = 1;
      for (int i : groups[size_t(held[h])])
        tests[h][int(std::lround(shape_.lights()[size_t(i)].theta_deg / 15.0)) * 15].push_back(i);
    }
    for (size_t g = 0; g < groups.size(); ++g)
      if (!out[g]) train.insert(train.end(), groups[g].begin(), groups[g].end());
    std::sort(train.begin(), train.end());
  }
  std::vector<ReconstructionSums> held_sums(held.size());
  ReconstructionSums held_all;
  const int passes = held.empty() ? 1 : 2;
  for (int b = 0; b < bands; ++b) {
    auto band = cache_->Load(b);
    if (!band.ok()) return band.status();
    if (tone_ && tone_->corrected) band->Relinearise(tone_->to, tone_reason_);
    FitOptions bo = o;  // the band's runs as its share of every band's (and pass's)
    bo.progress = [&](int64_t d, int64_t t) {
      return !progress || t <= 0 ||
             progress(int64_t(b * passes) * t + d, int64_t(bands) * passes * t);
    };
    auto fit = RefineSvbrdf(*band, *start_, cache_->band_row0(b), bo);
    if (!fit.ok()) return fit.status();
    const ReconstructionMetrics m = Reconstruction(*band, fit->maps, fit->status);
    sse += m.rmse * m.rmse * double(m.samples), samples += double(m.samples);
    const ReconstructionMetrics mc =
        AnyFlagged(fit->status) ? Reconstruction(*band, fit->maps, CommonTexelStatus(fit->status))
                                : m;
    sse_common += mc.rmse * mc.rmse * double(mc.samples), samples_common += double(mc.samples);
    AddDeviationByViewTheta(*band, fit->maps, fit->status, &view_theta_);
    // The band's rows into the whole maps.
    const int64_t off = int64_t(cache_->band_row0(b)) * W, T = band->plane_size();
    auto put = [&](const Image& src, Image* dst) {
      for (int c = 0; c < src.channels(); ++c)
        std::copy(src.Plane(c).begin(), src.Plane(c).end(), dst->Plane(c).begin() + off);
    };
    put(fit->maps.normal, &r.maps.normal);
    put(fit->maps.albedo, &r.maps.albedo);
    put(fit->maps.specular, &r.maps.specular);
    put(fit->maps.roughness, &r.maps.roughness);
    std::copy(fit->status.begin(), fit->status.end(), r.status.begin() + off);
    if (!held.empty()) {  // the band's texels fitted without the held-out views, then scored
      FitOptions ho = o;
      ho.progress = [&](int64_t d, int64_t t) {
        return !progress || t <= 0 ||
               progress(int64_t(b * passes + 1) * t + d, int64_t(bands) * passes * t);
      };
      auto hf = RefineSvbrdf(BorrowImages(*band, train), *start_, cache_->band_row0(b), ho);
      if (!hf.ok()) return hf.status();
      for (size_t h = 0; h < held.size(); ++h)
        for (const auto& [tl, images] : tests[h]) {
          const ReconstructionMetrics hm =
              ScoreStack(*band, images, hf->maps, hf->status, {},
                         {.reconstruction = true, .residuals = false, .srgb8 = true})
                  .reconstruction;
          held_sums[h].Add(hm, tl), held_all.Add(hm, tl);
        }
    }
    r.fit_seconds += fit->fit_seconds;
    int64_t ok = 0;
    for (int64_t p = 0; p < T; ++p) ok += fit->status[size_t(p)] == kTexelOk;
    iterations += fit->parameters["mean_lm_iterations"] * double(ok);
    used += fit->parameters["mean_samples_used"] * double(ok);
    fitted += double(ok);
    if (b == 0) r.parameters = fit->parameters;
  }
  r.parameters["mean_lm_iterations"] = fitted > 0 ? iterations / fitted : 0;
  r.parameters["mean_samples_used"] = fitted > 0 ? used / fitted : 0;
  r.parameters["streamed_bands"] = cache_->bands();
  heldout_views_.reset();
  if (!held.empty()) {
    HeldOutViewMetrics hv;
    hv.train_views = int(groups.size() - held.size());
    hv.all = held_all.Metrics();
    for (size_t h = 0; h < held.size(); ++h) {
      const LightSample& l = shape_.lights()[size_t(groups[size_t(held[h])][0])];
      hv.views.push_back({l.view_theta_deg, l.view_phi_deg, held_sums[h].Metrics()});
    }
    std::sort(hv.views.begin(), hv.views.end(), [](const HeldOutView& a, const HeldOutView& b) {
      return std::pair(a.theta_deg, a.phi_deg) < std::pair(b.theta_deg, b.phi_deg);
    });
    heldout_views_ = std::move(hv);
  }
  SummariseStatus(&r);
  // The whole stack's figures from the bands' sums.
  reconstruction_ = MetricsFromSums(sse, samples);
  reconstruction_common_ = MetricsFromSums(sse_common, samples_common);
  std::map<int, std::pair<double, double>> by_light;
  for (const auto& [tv, m] : view_theta_)
    for (const auto& [tl, sn] : m) by_light[tl].first += sn.first, by_light[tl].second += sn.second;
  for (const auto& [tl, sn] : by_light)
    if (sn.second > 0) reconstruction_.deviation_percent_by_theta[tl] = sn.first / sn.second;
  return Status::Ok();
}

std::map<int, std::map<int, double>> StreamedFit::DeviationByViewTheta() const {
  return fit::DeviationByViewTheta(view_theta_);
}

}  // namespace matfit::fit
