"""Results as numpy arrays: a snapshot file (`pflow run -o`, `pflow fetch`, a back-end's job file; the layout of
docs/output-format.md) opened lazily, or a snapshot fetched from the back-end. Particle fields come in id order,
so the same row is the same particle at every step and in every file, whatever the ranks that wrote it."""
import numpy as np

from .errors import Error, NotFound


def _text(v):
    return v.decode() if isinstance(v, bytes) else str(v)


class Grid:
    """The back-end's grid fields of one snapshot: cell (i, j, k) spans origin + cell_size * (i, j, k) to
    origin + cell_size * (i+1, j+1, k+1) and is element [i, j, k] of each field."""

    def __init__(self, origin, cell_size, cells, fields, units=None):
        self.origin = np.asarray(origin, dtype=float)
        self.cell_size = float(cell_size)
        self.cells = tuple(int(c) for c in cells)
        self._fields = dict(fields)
        self.units = dict(units or {})

    @property
    def names(self):
        return sorted(self._fields)

    def __contains__(self, name):
        return name in self._fields

    def __getitem__(self, name):
        value = self._fields[name]
        if callable(value):
            value = self._fields[name] = value()
        return value

    def centres(self):
        """The cell centres along x, y and z (three 1-D arrays, m)."""
        return tuple(self.origin[a] + self.cell_size * (np.arange(self.cells[a]) + 0.5) for a in range(3))

    def __repr__(self):
        return "Grid(cells=%s, cell_size=%g m, fields=%s)" % (self.cells, self.cell_size, self.names)


class Snapshot:
    """One snapshot: `snap["position"]` is an (n, 3) array in id order; `snap.fields` the names; `snap.grid` the grid
    fields (None without); `snap.units[name]` SI units ("" = dimensionless)."""

    def __init__(self, step, time, n, fields, units=None, grid=None):
        self.step = int(step)
        self.time = float(time)
        self.n = int(n)
        self._fields = dict(fields)
        self.units = dict(units or {})
        self.grid = grid

    @property
    def fields(self):
        return sorted(self._fields)

    def __contains__(self, name):
        return name in self._fields

    def __getitem__(self, name):
        if name not in self._fields:
            raise KeyError("snapshot at step %d has no field %r (it has %s)" % (self.step, name, ", ".join(self.fields)))
        value = self._fields[name]
        if callable(value):
            value = self._fields[name] = value()
        return value

    def as_dict(self):
        return {name: self[name] for name in self.fields}

    def __repr__(self):
        return "Snapshot(step=%d, time=%g s, n=%d, fields=%s)" % (self.step, self.time, self.n, self.fields)


class Geometry:
    """The walls: triangle vertices (V, 3) m and indices (T, 3), each triangle's surface number, the surfaces'
    names; planes by point and normal."""

    def __init__(self, arrays):
        self._a = dict(arrays)

    def __getitem__(self, name):
        return self._a[name]

    def __contains__(self, name):
        return name in self._a

    @property
    def names(self):
        return sorted(self._a)

    @property
    def vertices(self):
        return self._a.get("vertices", np.zeros((0, 3)))

    @property
    def triangles(self):
        return self._a.get("triangles", np.zeros((0, 3), dtype=np.uint32))

    @property
    def triangle_surface(self):
        return self._a.get("triangle_surface", np.zeros(0, dtype=np.int32))

    @property
    def surface_names(self):
        return [_text(s) for s in self._a.get("surface_names", [])]

    def triangles_of(self, surface):
        """The (k, 3, 3) corner coordinates of the triangles of the surface named `surface`."""
        names = self.surface_names
        if surface not in names:
            raise KeyError("no surface %r (surfaces: %s)" % (surface, ", ".join(names)))
        mask = self.triangle_surface == names.index(surface)
        return self.vertices[self.triangles[mask]]

    def __repr__(self):
        return "Geometry(%d triangles, surfaces=%s)" % (len(self.triangles), self.surface_names)


class Results:
    """A snapshot file, read lazily: `steps`, `times`, `snapshot(step)` (default: the last), iteration over the
    snapshots, `geometry`, `series` (the run's time series, /probes), `to_xarray()`. Use as a context manager or
    close() it."""

    def __init__(self, path):
        import h5py

        self.path = str(path)
        try:
            self._f = h5py.File(self.path, "r")
        except OSError as e:
            raise NotFound("cannot open %s as a snapshot file: %s" % (self.path, e)) from None
        fmt = _text(self._f.attrs.get("format", ""))
        if fmt != "pflow-snapshots":
            self._f.close()
            raise Error("%s is not a pflow snapshot file (format %r)" % (self.path, fmt))
        group = self._f.get("snapshots")
        self.steps = sorted(int(k) for k in group) if group is not None else []
        self.times = np.array([float(group[str(s)].attrs["time"]) for s in self.steps])
        self._geometry = None
        self._series = None

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    def close(self):
        self._f.close()

    def __len__(self):
        return len(self.steps)

    def __iter__(self):
        for s in self.steps:
            yield self.snapshot(s)

    @property
    def last(self):
        return self.snapshot()

    def snapshot(self, step=None):
        if not self.steps:
            raise NotFound("%s has no snapshots" % self.path)
        step = self.steps[-1] if step is None else int(step)
        if step not in self.steps:
            raise NotFound("%s has no snapshot at step %d (steps %d..%d, %d snapshots)" % (self.path, step, self.steps[0],
                                                                                              self.steps[-1], len(self.steps)))
        g = self._f["snapshots"][str(step)]
        names = [k for k in g if k != "grid" and hasattr(g[k], "shape")]
        order = np.argsort(g["id"][...], kind="stable") if "id" in g else None

        def loader(name):
            def load():
                data = g[name][...]
                return data[order] if order is not None and len(data) == len(order) else data
            return load

        units = {k: _text(g[k].attrs.get("unit", "")) for k in names}
        grid = None
        if "grid" in g:
            gg = g["grid"]
            grid = Grid(gg.attrs["origin"], gg.attrs["cell_size"], gg.attrs["cells"],
                        {k: (lambda k=k: gg[k][...]) for k in gg}, {k: _text(gg[k].attrs.get("unit", "")) for k in gg})
        return Snapshot(step, g.attrs["time"], g.attrs.get("n", len(order) if order is not None else 0),
                        {k: loader(k) for k in names}, units, grid)

    def __getitem__(self, step):
        return self.snapshot(step)

    @property
    def geometry(self):
        if self._geometry is None:
            g = self._f.get("geometry")
            self._geometry = Geometry({k: g[k][...] for k in g} if g is not None else {})
        return self._geometry

    @property
    def series(self):
        """The run's time series (/probes): a dict of 1-D arrays, `time` first (s), then each probe or DEM series
        (kinetic_energy, contacts, force_z:<surface>, ...); empty when the file has none."""
        if self._series is None:
            p = self._f.get("probes")
            self._series = {}
            if p is not None:
                if "time" in p:
                    self._series["time"] = p["time"][...]
                for k in p:
                    if k != "time":
                        self._series[k] = p[k][...]
        return self._series

    def to_xarray(self, fields=None):
        """The particle fields of every snapshot as an xarray.Dataset over (time, particle[, component]); needs
        xarray, and the same particles at every step (a run without insertion or removal)."""
        try:
            import xarray as xr
        except ImportError:
            raise Error("to_xarray() needs xarray (pip install xarray, or apt-get install python3-xarray)") from None
        snaps = list(self)
        if not snaps:
            raise NotFound("%s has no snapshots" % self.path)
        n = {s.n for s in snaps}
        if len(n) != 1:
            raise Error("to_xarray(): the particle count changes between snapshots (%s); read snapshots one by one" % sorted(n))
        names = fields or [f for f in snaps[0].fields if f != "id"]
        data = {}
        for name in names:
            stack = np.stack([s[name] for s in snaps])
            dims = ("time", "particle") + (("component",) if stack.ndim == 3 else ())
            data[name] = xr.DataArray(stack, dims=dims, attrs={"units": snaps[0].units.get(name, "")})
        coords = {"time": ("time", self.times, {"units": "s"}), "step": ("time", np.array(self.steps))}
        if "id" in snaps[0]:
            coords["particle"] = ("particle", snaps[0]["id"])
        return xr.Dataset(data, coords=coords, attrs={"source": self.path})

    def __repr__(self):
        return "Results(%r, %d snapshots, t = %s)" % (self.path, len(self.steps),
                                                     "%g..%g s" % (self.times[0], self.times[-1]) if len(self.times) else "-")


def open(path):  # noqa: A001 (pflow.open, as the issue names it)
    """Opens a snapshot file (`pflow run -o`, `pflow fetch -o`, a back-end's job file) as Results."""
    return Results(path)
