// One error type for host code. Device code uses Conditions flags; gRPC adapters map to grpc::Status.
#pragma once
#include <string>
#include <utility>
#include <variant>
#include <vector>

namespace pflow {

enum class StatusCode {
  kOk = 0,
  kInvalidArgument,
  kNotFound,
  kFailedPrecondition,
  kResourceExhausted,
  kInternal,
  kIo,
  kNumerical,
  kUnavailable,
  kAlreadyExists,
  kCancelled,
  kDeadlineExceeded,
  kUnauthenticated,   // no credentials, or ones that are not valid
  kPermissionDenied,  // valid credentials without the right to this
};

const char* statusCodeName(StatusCode code);

class Status {
 public:
  Status() = default;
  Status(StatusCode code, std::string message) : m_code(code), m_message(std::move(message)) {}
  static Status ok() { return {}; }
  bool isOk() const { return m_code == StatusCode::kOk; }
  explicit operator bool() const { return isOk(); }
  StatusCode code() const { return m_code; }
  const std::string& message() const { return m_message; }
  std::string toString() const;

 private:
  StatusCode m_code = StatusCode::kOk;
  std::string m_message;
};

inline Status invalidArgument(std::string m) { return {StatusCode::kInvalidArgument, std::move(m)}; }
inline Status ioError(std::string m) { return {StatusCode::kIo, std::move(m)}; }
inline Status internalError(std::string m) { return {StatusCode::kInternal, std::move(m)}; }
inline Status numericalError(std::string m) { return {StatusCode::kNumerical, std::move(m)}; }
inline Status notFound(std::string m) { return {StatusCode::kNotFound, std::move(m)}; }
inline Status failedPrecondition(std::string m) { return {StatusCode::kFailedPrecondition, std::move(m)}; }
inline Status resourceExhausted(std::string m) { return {StatusCode::kResourceExhausted, std::move(m)}; }
inline Status unavailable(std::string m) { return {StatusCode::kUnavailable, std::move(m)}; }
inline Status alreadyExists(std::string m) { return {StatusCode::kAlreadyExists, std::move(m)}; }
inline Status unauthenticated(std::string m) { return {StatusCode::kUnauthenticated, std::move(m)}; }
inline Status permissionDenied(std::string m) { return {StatusCode::kPermissionDenied, std::move(m)}; }

// A value or an error.
template <class T>
class Result {
 public:
  Result(T value) : m_v(std::move(value)) {}  // NOLINT(implicit)
  Result(Status status) : m_v(std::move(status)) {}  // NOLINT(implicit)
  bool isOk() const { return std::holds_alternative<T>(m_v); }
  explicit operator bool() const { return isOk(); }
  const Status& status() const {
    static const Status kOk;
    return isOk() ? kOk : std::get<Status>(m_v);
  }
  T& value() & { return std::get<T>(m_v); }
  const T& value() const& { return std::get<T>(m_v); }
  T&& value() && { return std::get<T>(std::move(m_v)); }
  T* operator->() { return &value(); }
  const T* operator->() const { return &value(); }
  T& operator*() { return value(); }

 private:
  std::variant<T, Status> m_v;
};

// One validation problem: where (a key path such as `particles[1].radius`) and what is wrong.
struct FieldError {
  std::string path;
  std::string message;
  int line = 0;    // 1-based source line, 0 when unknown
  int column = 0;  // 1-based source column, 0 when unknown
  std::string toString() const;
};

// Collects every problem so a user sees all of them at once.
class ErrorList {
 public:
  void add(std::string path, std::string message, int line = 0, int column = 0) {
    m_errors.push_back({std::move(path), std::move(message), line, column});
  }
  void append(const ErrorList& other) { m_errors.insert(m_errors.end(), other.m_errors.begin(), other.m_errors.end()); }
  bool empty() const { return m_errors.empty(); }
  std::size_t size() const { return m_errors.size(); }
  const std::vector<FieldError>& errors() const { return m_errors; }
  std::string toString() const;  // one error per line
  Status toStatus(const std::string& what) const;

 private:
  std::vector<FieldError> m_errors;
};

}  // namespace pflow

// Returns the status of `expr` from the enclosing function when it is not OK.
#define PFLOW_TRY(expr)               \
  do {                                \
    ::pflow::Status _st = (expr);     \
    if (!_st.isOk()) return _st;      \
  } while (0)
