"""Type aliases shared by the public API's annotations (issue 37; ``afferent/py.typed``).

Option choices are ``typing.Literal`` aliases defined beside the tuple their validator checks
(``METHODS = get_args(SamplingMethod)`` in :mod:`afferent.sampling`, ...): one list of values.
"""

from __future__ import annotations

import os
from collections.abc import Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = ["Accept", "ArrayLike", "NDArray", "PathLike", "RngLike"]

#: A file or folder name: ``str`` or any ``os.PathLike``.
PathLike = str | os.PathLike
#: A random generator, or a seed for one (``None``: fresh entropy).
RngLike = int | np.random.Generator | None
#: Checks whose unusual case the caller confirms, by name (:data:`afferent._validation.ACCEPTS`).
Accept = str | Sequence[str] | None
