#include "common/Status.h"

#include <sstream>

namespace pflow {

const char* statusCodeName(StatusCode code) {
  switch (code) {
    case StatusCode::kOk: return "OK";
    case StatusCode::kInvalidArgument: return "INVALID_ARGUMENT";
    case StatusCode::kNotFound: return "NOT_FOUND";
    case StatusCode::kFailedPrecondition: return "FAILED_PRECONDITION";
    case StatusCode::kResourceExhausted: return "RESOURCE_EXHAUSTED";
    case StatusCode::kInternal: return "INTERNAL";
    case StatusCode::kIo: return "IO";
    case StatusCode::kNumerical: return "NUMERICAL";
    case StatusCode::kUnavailable: return "UNAVAILABLE";
    case StatusCode::kAlreadyExists: return "ALREADY_EXISTS";
    case StatusCode::kCancelled: return "CANCELLED";
    case StatusCode::kDeadlineExceeded: return "DEADLINE_EXCEEDED";
    case StatusCode::kUnauthenticated: return "UNAUTHENTICATED";
    case StatusCode::kPermissionDenied: return "PERMISSION_DENIED";
  }
  return "UNKNOWN";
}

std::string Status::toString() const {
  if (isOk()) return "OK";
  return std::string(statusCodeName(m_code)) + ": " + m_message;
}

std::string FieldError::toString() const {
  std::ostringstream os;
  if (line > 0) os << "line " << line << ", column " << column << ": ";
  os << (path.empty() ? "<scene>" : path) << ": " << message;
  return os.str();
}

std::string ErrorList::toString() const {
  std::string out;
  for (const auto& e : m_errors) {
    out += e.toString();
    out += '\n';
  }
  return out;
}

Status ErrorList::toStatus(const std::string& what) const {
  if (empty()) return Status::ok();
  return invalidArgument(what + ": " + std::to_string(size()) + " error(s)\n" + toString());
}

}  // namespace pflow
