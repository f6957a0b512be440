"""Execute the teaching notebooks top to bottom and store them with their outputs.

Run from the repository root after editing a notebook::

    python notebooks/execute_notebooks.py                      # all of them
    python notebooks/execute_notebooks.py notebooks/04_calibration.ipynb

The notebooks are stored executed so that the documentation (myst-nb, which renders them
without executing) and GitHub show their figures. Each stored notebook records the SHA-256
of its code cells (``metadata.afferent.code_sha256``); ``tests/test_notebooks.py`` checks that
the stored outputs come from the stored code, so a code edit without re-running this script
fails the tests. Figures use Jupyter's inline backend, as in JupyterLab. Prints the wall time
of each notebook.
"""

from __future__ import annotations

import hashlib
import os
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent


def code_digest(nb) -> str:
    """SHA-256 (hex) of the notebook's code cells, in order."""
    h = hashlib.sha256()
    for cell in nb.cells:
        if cell.cell_type == "code":
            h.update(cell.source.encode())
            h.update(b"\0")
    return h.hexdigest()


def execute(path: Path, *, timeout: int = 600) -> float:
    """Execute ``path`` in place (cwd = its folder) and store it; returns the wall time in s."""
    import nbclient
    import nbformat

    nb = nbformat.read(path, as_version=4)
    env_backend = os.environ.pop("MPLBACKEND", None)  # let ipykernel choose its inline backend
    env_path = os.environ.get("PYTHONPATH")
    # the kernel imports the package of this checkout, not whichever one is installed
    os.environ["PYTHONPATH"] = os.pathsep.join(filter(None, [str(HERE.parent), env_path]))
    try:
        t = time.perf_counter()
        nbclient.NotebookClient(nb, timeout=timeout, kernel_name="python3",
                                resources={"metadata": {"path": str(path.parent)}}).execute()
        elapsed = time.perf_counter() - t
    finally:
        if env_backend is not None:
            os.environ["MPLBACKEND"] = env_backend
        if env_path is None:
            del os.environ["PYTHONPATH"]
        else:
            os.environ["PYTHONPATH"] = env_path
    nb.metadata.setdefault("afferent", {})["code_sha256"] = code_digest(nb)
    nbformat.write(nb, path)
    return elapsed


def main(argv=None) -> int:
    paths = [Path(p) for p in (argv if argv is not None else sys.argv[1:])] or sorted(HERE.glob("*.ipynb"))
    total = 0.0
    for p in paths:
        s = execute(p.resolve())
        total += s
        print(f"{p.name}: {s:.1f} s")
    print(f"total: {total:.1f} s")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
