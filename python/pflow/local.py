"""Local runs and checks through the `pflow` CLI binary (found as PFLOW_CLI, else `pflow` on PATH): `run` writes the
scene (a file, a dict or a Scene, with overrides) and runs it in a process of its own, returning its Results;
`validate` checks a scene and returns `pflow validate --json`'s summary, or raises SceneError with every finding."""
import json
import os
import shutil
import subprocess
import tempfile

from .errors import Error, SceneError
from .results import Results



def cli():
    path = os.environ.get("PFLOW_CLI") or shutil.which("pflow")
    if not path:
        raise Error("the pflow CLI was not found: put it on PATH or set PFLOW_CLI (for a build tree: build/bin/pflow)")
    return path


def _scene_file(scene, overrides, folder):
    """The scene as a YAML file in `folder` (a path, a dict or a Scene; overrides applied), and the folder its
    relative file names resolve against."""
    from .scene import Scene

    if isinstance(scene, (str, os.PathLike)) and not overrides:
        return os.fspath(scene)
    s = scene if isinstance(scene, Scene) else Scene.load(scene) if isinstance(scene, (str, os.PathLike)) else Scene(scene)
    s = s.with_overrides(overrides) if overrides else s
    return s.write(os.path.join(folder, "scene.yaml"))


def validate(scene, **overrides):
    """Checks a scene (a path, a dict or a Scene) with `pflow validate`: its summary as a dict (particles, dt, model,
    memory estimate, ...), or SceneError listing every finding with its key path."""
    with tempfile.TemporaryDirectory(prefix="pflow-validate-") as tmp:
        path = _scene_file(scene, overrides, tmp)
        r = subprocess.run([cli(), "validate", path, "--json"], capture_output=True, text=True)
    try:
        out = json.loads(r.stdout)
    except ValueError:
        raise Error("pflow validate %s: %s" % (path, (r.stderr or r.stdout).strip())) from None
    if out.get("valid") is False or r.returncode != 0:
        text = out.get("errors", "") if isinstance(out.get("errors"), str) else "\n".join(out.get("errors", []))
        raise SceneError.from_text(text.strip(), text)
    return out


def run(scene, output=None, executor="auto", threads=None, steps=None, **overrides):
    """Runs a scene locally (`pflow run`, its own process) and returns the Results of its snapshot file. `scene`: a
    path, a dict or a Scene; `overrides`: dotted keys, e.g. run("drum.yaml", **{"simulation.duration": 0.1}) (or
    simulation__duration=0.1). The file goes to `output` (default: run.h5 in a new temporary folder, left in place).
    Raises SceneError for an invalid scene, Error with the CLI's message when the run fails."""
    overrides = {k.replace("__", "."): v for k, v in overrides.items()}
    folder = tempfile.mkdtemp(prefix="pflow-run-")
    path = _scene_file(scene, overrides, folder)
    output = os.fspath(output) if output else os.path.join(folder, "run.h5")
    cmd = [cli(), "run", path, "-o", output, "--progress", "0", "--executor", executor]
    if threads:
        cmd += ["--threads", str(threads)]
    if steps is not None:
        cmd += ["--steps", str(steps)]
    r = subprocess.run(cmd, capture_output=True, text=True)
    if r.returncode != 0:
        message = (r.stderr or r.stdout).strip()
        if r.returncode == 1 and "error(s)" in message:
            validate(path)  # raises SceneError with the findings
        raise Error("pflow run %s failed (exit code %d): %s" % (path, r.returncode, message.splitlines()[-1] if message else ""))
    return Results(output)
