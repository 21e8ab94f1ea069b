"""Opens sample runs' .xmf files with ParaView's XDMF readers and checks what they produce.

usage: pvpython check_snapshot_paraview.py SAMPLE_WRITER WORK_DIR

Cases: with geometry (spatial collection per step), without geometry, and a live run whose writer still holds the
.h5 open. Readers: Xdmf3ReaderS, Xdmf3ReaderT, and the legacy XDMFReader (which drops empty particle sets).
"""
import os
import shutil
import subprocess
import sys

from paraview import servermanager
from paraview.simple import Delete, Xdmf3ReaderS, Xdmf3ReaderT, XDMFReader

EXPECTED_N = {0.0: 10, 0.001: 25, 0.002: 0}
POINT_ARRAYS = {"id", "velocity", "angular_velocity", "radius", "material", "contacts", "flags"}
READERS = {
    "Xdmf3ReaderS": lambda path: Xdmf3ReaderS(FileName=[path]),
    "Xdmf3ReaderT": lambda path: Xdmf3ReaderT(FileName=[path]),
    "XDMFReader": lambda path: XDMFReader(FileNames=[path]),
}


def leaves(data):
    """Leaf datasets of a (possibly nested) composite, in order."""
    if data is None:
        return []
    if not data.IsA("vtkCompositeDataSet"):
        return [data]
    out = []
    it = data.NewIterator()
    it.InitTraversal()
    while not it.IsDoneWithTraversal():
        out.append(it.GetCurrentDataObject())
        it.GoToNextItem()
    return out


def check_particles(t, n, particles, problems):
    if particles.GetNumberOfPoints() != n or particles.GetNumberOfCells() != n:
        problems.append(f"t={t}: {particles.GetNumberOfPoints()} points, {particles.GetNumberOfCells()} cells")
        return
    if n == 0:
        return
    pd = particles.GetPointData()
    arrays = {pd.GetArrayName(i) for i in range(pd.GetNumberOfArrays())}
    if arrays != POINT_ARRAYS:
        problems.append(f"t={t}: point arrays {sorted(arrays)}")
        return
    vel = pd.GetArray("velocity")
    if vel.GetNumberOfComponents() != 3 or vel.GetTuple3(2) != (-1.0, 0.0, 1.0):
        problems.append(f"t={t}: velocity {vel.GetNumberOfComponents()} comps, {vel.GetTuple3(2)}")
    if int(pd.GetArray("id").GetTuple1(n - 1)) != 1000 + n - 1:
        problems.append(f"t={t}: id {pd.GetArray('id').GetTuple1(n - 1)}")
    if int(pd.GetArray("flags").GetTuple1(0)) != -3:
        problems.append(f"t={t}: flags {pd.GetArray('flags').GetTuple1(0)}")
    x = particles.GetPoint(n - 1)
    step = round(t * 1e5)  # the sample writes step 100 at t = 1e-3
    want = tuple(0.01 * (n - 1) + 0.1 * c + 1e-3 * step for c in range(3))
    if max(abs(a - b) for a, b in zip(x, want)) > 1e-12:
        problems.append(f"t={t}: last point {x} vs {want}")


def check_reader(label, xmf, with_geometry):
    reader = READERS[label](xmf)
    reader.UpdatePipelineInformation()
    times = [round(t, 9) for t in reader.TimestepValues]
    problems = []
    if times != sorted(EXPECTED_N):
        problems.append(f"times {times}")
    for t, n in EXPECTED_N.items():
        reader.UpdatePipeline(t)
        blocks = leaves(servermanager.Fetch(reader))
        if label == "XDMFReader" and n == 0:
            continue  # the legacy reader reports an error for an empty geometry and drops that grid
        if len(blocks) != (2 if with_geometry else 1):
            problems.append(f"t={t}: {len(blocks)} blocks")
            continue
        check_particles(t, n, blocks[0], problems)
        if with_geometry:
            geometry = blocks[1]
            if geometry.GetNumberOfCells() != 3 or geometry.GetNumberOfPoints() != 5:
                problems.append(f"t={t}: geometry {geometry.GetNumberOfPoints()} points, "
                                f"{geometry.GetNumberOfCells()} cells")
            surface = geometry.GetCellData().GetArray("triangle_surface")
            if surface is None or [surface.GetTuple1(i) for i in range(3)] != [1.0, 1.0, 2.0]:
                problems.append(f"t={t}: triangle_surface {surface}")
    Delete(reader)
    return problems


def run_case(writer, work, name, extra, hold_open=False):
    case_dir = os.path.join(work, name)
    os.makedirs(case_dir)
    h5 = os.path.join(case_dir, "sample.h5")
    proc = subprocess.Popen([writer, h5] + extra + (["--hold-open"] if hold_open else []),
                            stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
    xmf = proc.stdout.readline().strip()  # printed once every snapshot is written
    failed = 0
    try:
        for label in READERS:
            problems = check_reader(label, os.path.abspath(xmf), with_geometry=not extra)
            print(f"{name} / {label}: {'ok' if not problems else '; '.join(problems)}")
            failed += bool(problems)
    finally:
        proc.communicate("\n")
    if proc.returncode != 0:
        print(f"{name}: sample writer exited with {proc.returncode}")
        failed += 1
    return failed


def main():
    writer, work = sys.argv[1], sys.argv[2]
    shutil.rmtree(work, ignore_errors=True)
    os.makedirs(work)
    cases = [("geometry", [], False), ("no_geometry", ["--no-geometry"], False), ("live", [], True)]
    failed = sum(run_case(writer, work, name, extra, hold) for name, extra, hold in cases)
    total = len(cases) * len(READERS)
    print(f"{total - failed} passed, {failed} failed")
    sys.exit(1 if failed else 0)


if __name__ == "__main__":
    main()
