"""Free loopback ports for the test stacks (tests/services, python/tests/conftest.py)."""
import socket

_given = set()


def free_port():
    """A free loopback port, never one this process was given before: a port closed at once may be handed out again
    by the next bind, and two services would then race for one."""
    while True:
        with socket.socket() as s:
            s.bind(("127.0.0.1", 0))
            port = s.getsockname()[1]
        if port not in _given:
            _given.add(port)
            return port
