// Runs one job with the same controllers as the CLI (fit::RunFitJob, leaf::RunLeafJob), its
// files confined to the dataset folder, its pack written atomically to `out_dir`.
#pragma once

#include <cstdint>
#include <functional>
#include <string>

#include "core/dataset/dataset.h"
#include "core/status.h"
#include "server/job_spec.h"

namespace matfit::server {

// The check at submission time, without decoding a pixel: the folder holds a dataset of the
// job's kind; every file it names lies inside it; the light files parse; the image headers agree
// and images × width × height × channels ≤ max_stack_samples (0 = no limit). Errors carry the
// reader's message (unknown layout, no back-lit images, a link out of the folder, ...). Beyond
// the reader: a light file that leaves numbered images without a light, more held-out folds
// than images, model=auto with fewer than 3 images. *field (optional) names the job field the
// error is about ("holdout", "model", "layout", "view") or "file"/"dataset" for the data.
Status ValidateDataset(const JobSpec& spec, const std::string& dir, int64_t max_stack_samples = 0,
                       std::string* field = nullptr);
// The read options a job's fields ask for (layout, colour space, view).
ReadOptions JobReadOptions(const JobSpec& spec);

// fraction of the whole job in [0, 1], the current stage name; return false to cancel.
using JobProgress = std::function<bool(double fraction, const std::string& stage)>;

// Returns the report summary (JSON object text) of a succeeded job; kCancelled when progress
// returned false. out_dir is replaced atomically (overwrite: a re-run after a crash).
// source_label is what the pack names as its input (empty: `dataset`); the server never
// passes its own folders. The stack limit is applied again (the files of a dataset named by
// path may change after submission).
StatusOr<std::string> RunJob(const JobSpec& spec, const std::string& dataset,
                             const std::string& out_dir, const JobProgress& progress,
                             const std::string& source_label = "", int64_t max_stack_samples = 0);

}  // namespace matfit::server
