"""Progress bars (tqdm) only when asked for: with progress off, tqdm is not even imported.

Importing ``tqdm.auto`` in a Jupyter kernel without ipywidgets prints "IProgress not found",
even for a disabled bar; :func:`progress_bar` returns a silent stand-in instead when the bar is
off, so notebooks and scripts that do not ask for progress see nothing.
"""

from __future__ import annotations

__all__ = ["progress_bar"]


class _Silent:
    """What a disabled tqdm bar does: iterate, count, close - and print nothing."""

    def __init__(self, iterable=None):
        self._iterable = iterable

    def __iter__(self):
        return iter(self._iterable)

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        return False

    def update(self, n=1):
        pass

    def set_postfix(self, *args, **kwargs):
        pass

    def close(self):
        pass


def progress_bar(iterable=None, *, enabled: bool, **kwargs):
    """A tqdm bar over ``iterable`` (``kwargs`` as for :class:`tqdm.tqdm`) if ``enabled``, else a silent one."""
    if not enabled:
        return _Silent(iterable)
    from tqdm.auto import tqdm

    return tqdm(iterable, **kwargs)
