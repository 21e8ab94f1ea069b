"""pflow's errors as Python exceptions: the service's own message, and the same classes the CLI's exit codes name."""
import re

# One finding of the scene loader's report: "[line L, column C: ]key.path: message".
_FINDING = re.compile(r"^(?:line \d+, column \d+: )?([A-Za-z0-9_\[\].:/-]*): (.*)$")


class Error(Exception):
    """Anything pflow refused or could not do; `str(e)` is the message the service (or the CLI) gave."""

    code = "UNKNOWN"

    def __init__(self, message, code=None):
        super().__init__(message)
        self.message = message
        if code:
            self.code = code


class InvalidArgument(Error):
    """A malformed request: the message names each bad field (CLI exit code 1)."""
    code = "INVALID_ARGUMENT"


class SceneError(InvalidArgument):
    """An invalid scene: `errors` lists (path, message) for each finding, every one at once."""

    def __init__(self, message, errors=()):
        super().__init__(message)
        self.errors = list(errors)

    @classmethod
    def from_text(cls, message, text):
        """From the loader's report (`pflow validate`, a build's reason): a first line, then one finding a line as
        `[line L, column C: ]key.path: message`."""
        findings = []
        for line in text.splitlines()[1:]:
            m = _FINDING.match(line.strip())
            if m:
                findings.append((m.group(1), m.group(2)))
        return cls(message, findings)



class NotFound(Error):
    """An unknown job, step or file (CLI exit code 1)."""
    code = "NOT_FOUND"


class Unauthenticated(Error):
    """No token, or one that is not valid (CLI exit code 7)."""
    code = "UNAUTHENTICATED"


class PermissionDenied(Error):
    """A valid token, but not for this (another user's job; an admin's call) (CLI exit code 7)."""
    code = "PERMISSION_DENIED"


class Unavailable(Error):
    """A service cannot be reached, or did not answer in time (CLI exit code 4)."""
    code = "UNAVAILABLE"


class Refused(Error):
    """Too few free devices and the job may not wait, or a job that can never fit (CLI exit code 5)."""
    code = "RESOURCE_EXHAUSTED"


def from_rpc(error, what, address=""):
    """A grpc.RpcError as the pflow exception of its code, with the server's message."""
    import grpc

    code = error.code() if hasattr(error, "code") else None
    detail = error.details() if hasattr(error, "details") else str(error)
    message = "%s: %s" % (what, detail)
    if code in (grpc.StatusCode.UNAVAILABLE, grpc.StatusCode.DEADLINE_EXCEEDED):
        return Unavailable("%s: cannot reach %s (%s); is the service running? Set the address with Client(manager=..., "
                           "backend=...), PFLOW_MANAGER/PFLOW_BACKEND or ~/.config/pflow/config.yaml" % (what, address, detail))
    cls = {
        grpc.StatusCode.INVALID_ARGUMENT: InvalidArgument,
        grpc.StatusCode.NOT_FOUND: NotFound,
        grpc.StatusCode.UNAUTHENTICATED: Unauthenticated,
        grpc.StatusCode.PERMISSION_DENIED: PermissionDenied,
        grpc.StatusCode.RESOURCE_EXHAUSTED: Refused,
        grpc.StatusCode.FAILED_PRECONDITION: Refused if "refused" in (detail or "") else Error,
    }.get(code, Error)
    e = cls(message)
    if cls is Error and code is not None:
        e.code = code.name
    return e
