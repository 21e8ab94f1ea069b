"""Scenes from Python: a dict in the YAML format of docs/scene-format.md, written as YAML and checked by
`pflow validate` (every finding at once, with its key path). Dotted overrides change nested keys:
Scene.load("drum.yaml").with_overrides({"simulation.duration": 0.5, "materials[0].friction": 0.3})."""
import copy
import os
import re

import yaml

from .errors import InvalidArgument

_PART = re.compile(r"([^.\[\]]+)|\[(\d+)\]")


class Scene:
    def __init__(self, data=None, base_dir=None):
        self.data = copy.deepcopy(dict(data or {}))
        self.base_dir = base_dir  # where its relative file names (meshes, CSV) resolve; None: the current folder

    @classmethod
    def load(cls, path):
        with open(path) as f:
            data = yaml.safe_load(f) or {}
        if not isinstance(data, dict):
            raise InvalidArgument("%s: a scene is a mapping of sections (materials, particles, ...)" % path)
        return cls(data, base_dir=os.path.dirname(os.path.abspath(path)))

    def __getitem__(self, key):
        return self.data[key]

    def __setitem__(self, key, value):
        self.data[key] = value

    def set(self, dotted, value):
        """Sets a nested key: "simulation.duration", "materials[0].friction"; missing mappings are made."""
        parts = [m.group(1) if m.group(1) is not None else int(m.group(2)) for m in _PART.finditer(dotted)]
        if not parts:
            raise InvalidArgument("override %r: not a key path" % dotted)
        node = self.data
        for here, nxt in zip(parts, parts[1:]):
            if isinstance(here, int):
                if not isinstance(node, list) or here >= len(node):
                    raise InvalidArgument("override %r: no item [%d] there" % (dotted, here))
                node = node[here]
            else:
                if not isinstance(node, dict):
                    raise InvalidArgument("override %r: %r is not a mapping" % (dotted, here))
                node = node.setdefault(here, [] if isinstance(nxt, int) else {})
        last = parts[-1]
        if isinstance(last, int):
            if not isinstance(node, list) or last >= len(node):
                raise InvalidArgument("override %r: no item [%d] there" % (dotted, last))
        node[last] = value
        return self

    def with_overrides(self, overrides):
        s = Scene(self.data, self.base_dir)
        for k, v in (overrides or {}).items():
            s.set(k, v)
        return s

    def files(self):
        """The files the scene refers to (meshes, particle CSV), as written."""
        out = []
        for g in self.data.get("geometry") or []:
            mesh = g.get("mesh") if isinstance(g, dict) else None
            if isinstance(mesh, dict) and isinstance(mesh.get("file"), str):
                out.append(mesh["file"])
        for p in self.data.get("particles") or []:
            if isinstance(p, dict) and isinstance(p.get("file"), str):
                out.append(p["file"])
        return out

    def to_yaml(self):
        return yaml.safe_dump(self.data, sort_keys=False, default_flow_style=None)

    def write(self, path):
        """Writes the YAML; relative file names are made absolute against base_dir so the copy still finds them."""
        data = copy.deepcopy(self.data)
        if self.base_dir:
            for g in data.get("geometry") or []:
                mesh = g.get("mesh") if isinstance(g, dict) else None
                if isinstance(mesh, dict) and isinstance(mesh.get("file"), str) and not os.path.isabs(mesh["file"]):
                    mesh["file"] = os.path.join(self.base_dir, mesh["file"])
            for p in data.get("particles") or []:
                if isinstance(p, dict) and isinstance(p.get("file"), str) and not os.path.isabs(p["file"]):
                    p["file"] = os.path.join(self.base_dir, p["file"])
        with open(path, "w") as f:
            yaml.safe_dump(data, f, sort_keys=False, default_flow_style=None)
        return os.fspath(path)

    def validate(self):
        """`pflow validate` of this scene: its summary, or SceneError with every finding."""
        from .local import validate

        return validate(self)

    def __repr__(self):
        return "Scene(%s)" % ", ".join(self.data)
