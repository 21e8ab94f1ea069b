"""Where the services are and who the caller is, looked up as the CLI does (README, "On a cluster"): an explicit
argument, then the environment (PFLOW_MANAGER, PFLOW_BACKEND, PFLOW_TOKEN, PFLOW_CA, PFLOW_INSECURE), then the
config file (PFLOW_CONFIG, else ~/.config/pflow/config.yaml: manager, backend, ca, token, insecure), then the
loopback defaults."""
import ipaddress
import os

import yaml

from .errors import InvalidArgument

DEFAULT_MANAGER = "127.0.0.1:50051"
DEFAULT_BACKEND = "127.0.0.1:50053"


def config_file():
    path = os.environ.get("PFLOW_CONFIG") or os.path.join(os.path.expanduser("~"), ".config", "pflow", "config.yaml")
    if not os.path.exists(path):
        return {}
    with open(path) as f:
        data = yaml.safe_load(f) or {}
    return data if isinstance(data, dict) else {}


def _one(given, env, key, cfg, fallback):
    if given:
        return given
    if os.environ.get(env):
        return os.environ[env]
    value = cfg.get(key)
    if value not in (None, ""):
        return str(value)
    return fallback


def host_of(address):
    if address.startswith("["):
        return address[1:address.index("]")]
    return address.rsplit(":", 1)[0] if ":" in address else address


def is_loopback(host):
    if host == "localhost":
        return True
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:
        return False


class Endpoints:
    def __init__(self, manager=None, backend=None, token=None, ca=None, insecure=None):
        cfg = config_file()
        self.manager = _one(manager, "PFLOW_MANAGER", "manager", cfg, DEFAULT_MANAGER)
        self.backend = _one(backend, "PFLOW_BACKEND", "backend", cfg, DEFAULT_BACKEND)
        self.token = _one(token, "PFLOW_TOKEN", "token", cfg, "")
        self.ca = _one(ca, "PFLOW_CA", "ca", cfg, "")
        if insecure is None:
            insecure = os.environ.get("PFLOW_INSECURE") == "1" or str(cfg.get("insecure", "")).lower() == "true"
        self.insecure = bool(insecure)
        if self.insecure and not (is_loopback(host_of(self.manager)) and is_loopback(host_of(self.backend))):
            raise InvalidArgument("insecure talks plaintext, and would send the token in the clear: only to services on loopback "
                                  "(%s, %s are not)" % (self.manager, self.backend))
        if not self.insecure and not self.ca:
            raise InvalidArgument("no pflow CA to verify the services with: give Client(ca=FILE), PFLOW_CA or `ca:` in "
                                  "~/.config/pflow/config.yaml (deploy/local/start.sh writes one), or insecure=True for a stack "
                                  "started with --insecure")
        if self.token and not all(32 <= ord(c) < 127 for c in self.token):
            raise InvalidArgument("the token has characters outside printable ASCII: it is not a pflow token")

    def channel(self, address):
        import grpc

        options = [("grpc.max_receive_message_length", 64 << 20), ("grpc.keepalive_time_ms", 20000),
                   ("grpc.keepalive_permit_without_calls", 1)]
        if self.insecure:
            return grpc.insecure_channel(address, options=options)
        with open(self.ca, "rb") as f:
            creds = grpc.ssl_channel_credentials(root_certificates=f.read())
        return grpc.secure_channel(address, creds, options=options)

    def metadata(self):
        return (("authorization", "Bearer " + self.token),) if self.token else ()
