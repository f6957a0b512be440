"""The SED level's plausibility check (afferent._plausibility.sed_warning), run at every step of a series.

The reference is the check as it was: the 99th percentile of the nonzero magnitudes (numpy's
linear interpolation) against the band. The fast decision (two counts, no sort) must give the same
warning, word for word, on fields inside, outside and straddling the band's edges.
"""

from __future__ import annotations

import numpy as np
import pytest

from afferent import _plausibility as P


def _reference(sed):
    level = P.robust_level(sed)
    if level == 0.0:
        v = np.asarray(sed, dtype=float)
        return "all zero" if v.size and np.all(v == 0) else None
    side = P._outside(level, P.SED_BAND_PA, ("below", "above"))
    return None if side is None else f"{level:.3g} {side}"


def _cases():
    rng = np.random.default_rng(7)
    lo, hi = P.SED_BAND_PA
    yield np.zeros(10)
    yield np.array([np.nan, 0.0, np.inf])
    yield from (np.array([lo]), np.array([hi]), np.array([np.nextafter(lo, 0)]), np.array([np.nextafter(hi, np.inf)]))
    for n in (1, 2, 3, 99, 100, 101, 102, 199, 1000, 30_001):
        base = rng.lognormal(0.0, 2.0, n)
        for scale in (1e-6, 1e-3, 1.0, 1e3, 1e6, 1e9):
            yield base * scale
        for edge in (lo, hi):  # the percentile's neighbours on, just below and just above an edge of the band
            v = np.sort(base / np.percentile(base, 99) * edge)
            k = int(np.floor((n - 1) * 0.99))
            for nudge in (0.0, -1e-12, 1e-12):
                w = v.copy()
                w[k:min(k + 2, n)] = edge * (1 + nudge)
                yield -rng.permutation(w)  # the magnitudes count: negative values too


@pytest.mark.parametrize("k_sed", list(enumerate(_cases())), ids=lambda c: str(c[0]))
def test_the_level_check_warns_as_the_percentile_does(k_sed):
    _, sed = k_sed
    got = P.sed_warning(sed, what="x", unit_hint="'sed_unit'")
    expected = _reference(sed)
    if expected is None:
        assert got is None
    elif expected == "all zero":
        assert "every SED value is 0" in got
    else:
        assert f"SED of {expected.split()[0]} J/m^3" in got and f"far {expected.split()[1]}" in got


def test_a_field_inside_the_band_is_judged_without_a_sort(monkeypatch):
    """2 ms of the 4.7 ms a 300,763-point step cost in iter_sed went to np.percentile's partial sort."""
    sed = np.random.default_rng(1).lognormal(3.0, 1.0, 300_000)  # Pa: a fingertip's SED
    calls = []
    percentile = np.percentile
    monkeypatch.setattr(np, "percentile", lambda *a, **k: calls.append(1) or percentile(*a, **k))
    assert P.sed_warning(sed, what="x", unit_hint="'sed_unit'") is None
    assert calls == []
    assert "far above" in P.sed_warning(sed * 1e6, what="x", unit_hint="'sed_unit'") and calls == [1]
