"""Benchmark: meshio against VTK's own readers on the same VTU files (why meshio stays the default).

Run from the repository root:  python benchmarks/bench_vtk_readers.py [FILE.vtu ...]

For each file: the median of 5 wall times of :func:`afferent.io._meshio.read_mesh_file` (meshio)
and of :func:`afferent.io._vtk.read_vtk_file` (VTK), after one warm-up read each, and the time to
import VTK's modules (once per process; measured first, in a fresh process). Both readers must
give the same points and arrays (checked). The install size is measured separately:
``du -sh $(python -c 'import vtkmodules, os; print(os.path.dirname(vtkmodules.__file__))')``.
"""

from __future__ import annotations

import statistics
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
DEFAULT = [ROOT / "sample_sed" / "block4" / "indent_0p88mm.vtu", ROOT / "sample_sed" / "block4" / "indent_0p88mm_tensors.vtu"]


def main(paths) -> None:
    t0 = time.perf_counter()
    import vtkmodules.vtkCommonDataModel  # noqa: F401
    import vtkmodules.vtkIOLegacy  # noqa: F401
    import vtkmodules.vtkIOXML  # noqa: F401
    t_import = time.perf_counter() - t0
    import numpy as np

    from afferent.io._meshio import read_mesh_file
    from afferent.io._vtk import read_vtk_file

    def median_ms(read, path):
        times = []
        for _ in range(5):
            t = time.perf_counter()
            read(path)
            times.append(time.perf_counter() - t)
        return 1e3 * statistics.median(times)

    print(f"import of VTK's modules: {1e3 * t_import:.0f} ms")
    for path in map(str, paths):
        a, b = read_mesh_file(path), read_vtk_file(path)
        same = np.array_equal(a.points, b.points) and all(
            np.array_equal(a.arrays[k].values.reshape(b.arrays[k].values.shape), b.arrays[k].values) for k in a.arrays)
        print(f"{path}: meshio {median_ms(read_mesh_file, path):.1f} ms, VTK {median_ms(read_vtk_file, path):.1f} ms "
              f"(medians of 5); same points and arrays: {same}")


if __name__ == "__main__":
    main(sys.argv[1:] or DEFAULT)
