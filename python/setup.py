"""Builds the pflow package with its gRPC stubs generated from ../proto at build time (never checked in): protoc with
Python output and grpc_python_plugin (Debian's protobuf-compiler and protobuf-compiler-grpc) write the modules of
pflow.*.v1 and grpc_std.* into the package's build folder. PFLOW_PROTO_DIR overrides where the protos are."""
import glob
import os
import shutil
import subprocess

from setuptools import setup
from setuptools.command.build_py import build_py

HERE = os.path.dirname(os.path.abspath(__file__))


class BuildWithStubs(build_py):
    def run(self):
        super().run()
        proto_dir = os.environ.get("PFLOW_PROTO_DIR", os.path.join(HERE, "..", "proto"))
        protos = sorted(glob.glob(os.path.join(proto_dir, "pflow", "**", "*.proto"), recursive=True) +
                        glob.glob(os.path.join(proto_dir, "grpc_std", "**", "*.proto"), recursive=True))
        if not protos:
            raise SystemExit("pflow: no .proto files under %s (set PFLOW_PROTO_DIR)" % proto_dir)
        plugin = shutil.which("grpc_python_plugin")
        protoc = shutil.which("protoc")
        if not plugin or not protoc:
            raise SystemExit("pflow: protoc and grpc_python_plugin are needed (apt-get install protobuf-compiler protobuf-compiler-grpc)")
        out = self.build_lib  # pflow/<svc>/v1/*_pb2*.py beside the package's own modules; grpc_std/ at the top
        subprocess.run([protoc, "--proto_path=" + proto_dir, "--python_out=" + out, "--grpc_python_out=" + out,
                        "--plugin=protoc-gen-grpc_python=" + plugin] + protos, check=True)
        for root, _dirs, _files in os.walk(os.path.join(out, "grpc_std")):
            open(os.path.join(root, "__init__.py"), "a").close()
        for sub in glob.glob(os.path.join(out, "pflow", "*", "")):
            for root, _dirs, _files in os.walk(sub):
                open(os.path.join(root, "__init__.py"), "a").close()


setup(cmdclass={"build_py": BuildWithStubs})
