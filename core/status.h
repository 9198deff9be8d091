// Status and StatusOr: how anything a user or a device can cause is reported.
// Invariants use MATFIT_CHECK (check.h); user-facing messages name the file, field or value
// that was wrong and what would fix it.
#pragma once

#include <optional>
#include <string>
#include <utility>

namespace matfit {

enum class StatusCode {
  kOk = 0,
  kInvalidArgument,  // a parameter or option value is out of range
  kNotFound,         // a file or folder does not exist
  kDataError,        // a file exists but its content is malformed
  kIoError,          // reading or writing failed at the OS level
  kUnavailable,      // a device or service cannot be reached
  kCancelled,        // the caller asked to stop
  kInternal,
};

const char* StatusCodeName(StatusCode code);

class [[nodiscard]] Status {
 public:
  Status() = default;
  Status(StatusCode code, std::string message) : code_(code), message_(std::move(message)) {}

  static Status Ok() { return {}; }
  bool ok() const { return code_ == StatusCode::kOk; }
  StatusCode code() const { return code_; }
  const std::string& message() const { return message_; }
  // "data error: <message>" or "ok".
  std::string ToString() const;

 private:
  StatusCode code_ = StatusCode::kOk;
  std::string message_;
};

inline Status InvalidArgument(std::string m) {
  return {StatusCode::kInvalidArgument, std::move(m)};
}
inline Status NotFound(std::string m) { return {StatusCode::kNotFound, std::move(m)}; }
inline Status DataError(std::string m) { return {StatusCode::kDataError, std::move(m)}; }
inline Status IoError(std::string m) { return {StatusCode::kIoError, std::move(m)}; }

// Either a value or a non-ok Status.
template <typename T>
class [[nodiscard]] StatusOr {
 public:
  StatusOr(T value) : value_(std::move(value)) {}          // NOLINT: implicit by design
  StatusOr(Status status) : status_(std::move(status)) {}  // NOLINT
  bool ok() const { return status_.ok(); }
  const Status& status() const { return status_; }
  T& value() & { return *value_; }
  const T& value() const& { return *value_; }
  T&& value() && { return std::move(*value_); }
  T* operator->() { return &*value_; }
  const T* operator->() const { return &*value_; }
  T& operator*() & { return *value_; }
  const T& operator*() const& { return *value_; }

 private:
  Status status_;
  std::optional<T> value_;
};

}  // namespace matfit

// Returns early from a function returning Status or StatusOr when `expr` is not ok.
#define MATFIT_RETURN_IF_ERROR(expr)                 \
  do {                                               \
    ::matfit::Status matfit_status_ = (expr);        \
    if (!matfit_status_.ok()) return matfit_status_; \
  } while (0)
