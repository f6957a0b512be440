"""Layout checks of a matplotlib Figure, as a reader sees it (display coordinates, after a draw).

:func:`figure_problems` returns one line per problem (empty list: the figure is readable):

- a legend box (an Axes' or the figure's) or a text placed in an Axes covers a plotted point:
  a line's vertex (not the segments between), a scatter offset or a bar (its rectangle clipped
  to its Axes: corners and centre);
- two labels overlap: tick labels (major and minor, those in view), axis labels, titles, the
  offset text (``x10^3``), texts placed in the Axes and the figure's titles, pairwise over the
  whole figure (so a twin Axes' labels and a colour bar's count too);
- a line hidden under a later one: the same vertices (within a pixel), drawn after it, opaque,
  solid, at least as wide and with markers at least as large;
- an axis label with more than one parenthesised part ("x (across the ridges) (mm)": the unit
  goes in the one pair of brackets);
- a figure without a title (an Axes title or the figure's suptitle).

:func:`collect_figure_problems` (a pytest fixture body) checks every figure saved while it is
active, by wrapping ``Figure.savefig``: the figures the package writes are checked as written.
"""

from __future__ import annotations

import itertools
import re

import numpy as np

#: Overlaps smaller than this (pixels, either direction) are rounding, not collisions.
TOLERANCE_PX = 0.5


def _points(fig):
    """Display coordinates (n, 2) of every plotted point, with the artist's label, per Axes."""
    from matplotlib.patches import Rectangle

    for ax in fig.axes:
        box = ax.get_window_extent()
        for line in ax.get_lines():
            if not line.get_visible():
                continue
            xy = np.column_stack([np.asarray(line.get_xdata(), float), np.asarray(line.get_ydata(), float)])
            xy = xy[np.all(np.isfinite(xy), axis=1)]
            if xy.size:
                yield ax, line.get_label(), _inside(line.get_transform().transform(xy), box)
        for coll in ax.collections:
            offs = np.asarray(coll.get_offsets(), float)
            if coll.get_visible() and offs.size and offs.ndim == 2:
                offs = offs[np.all(np.isfinite(offs), axis=1)]
                yield ax, coll.get_label(), _inside(coll.get_offset_transform().transform(offs), box)
        for patch in ax.patches:
            if isinstance(patch, Rectangle) and patch.get_visible() and patch.get_height() != 0:
                ext = patch.get_window_extent()
                x0, x1 = max(ext.x0, box.x0), min(ext.x1, box.x1)
                y0, y1 = max(ext.y0, box.y0), min(ext.y1, box.y1)
                if x1 > x0 and y1 > y0:  # the visible part of the bar, as its 4 corners and centre
                    yield ax, f"bar {patch.get_label()}", np.array(
                        [[x0, y0], [x0, y1], [x1, y0], [x1, y1], [(x0 + x1) / 2, (y0 + y1) / 2]])


def _inside(xy, box):
    keep = (xy[:, 0] >= box.x0 - 1) & (xy[:, 0] <= box.x1 + 1) & (xy[:, 1] >= box.y0 - 1) & (xy[:, 1] <= box.y1 + 1)
    return xy[keep]


def _legends(fig):
    out = [(ax, ax.get_legend()) for ax in fig.axes if ax.get_legend() is not None]
    return out + [(None, leg) for leg in fig.legends]


def _texts(fig, renderer):
    """(name, bbox) of every non-empty visible label of the figure."""
    out = []

    def add(name, text):
        if text.get_visible() and text.get_text().strip():
            out.append((name, text.get_window_extent(renderer)))

    for i, ax in enumerate(fig.axes):
        box = ax.get_window_extent(renderer)
        for axis, lo, hi in ((ax.xaxis, box.x0, box.x1), (ax.yaxis, box.y0, box.y1)):
            for tick in axis.get_major_ticks() + axis.get_minor_ticks():
                for lab in (tick.label1, tick.label2):
                    if not (lab.get_visible() and lab.get_text().strip()):
                        continue
                    ext = lab.get_window_extent(renderer)
                    mid = (ext.x0 + ext.x1) / 2 if axis is ax.xaxis else (ext.y0 + ext.y1) / 2
                    if lo - 1 <= mid <= hi + 1:
                        out.append((f"axes {i} {axis.axis_name} tick '{lab.get_text()}'", ext))
            add(f"axes {i} {axis.axis_name} label", axis.label)
            add(f"axes {i} {axis.axis_name} offset text", axis.get_offset_text())
        for t in (ax.title, ax._left_title, ax._right_title):
            add(f"axes {i} title", t)
        for t in ax.texts:
            add(f"axes {i} text '{t.get_text()[:30]}'", t)
    for t in fig.texts:  # suptitle, supxlabel, supylabel among them
        add(f"figure text '{t.get_text()[:30]}'", t)
    return out


def _overlap(a, b) -> bool:
    return (min(a.x1, b.x1) - max(a.x0, b.x0) > TOLERANCE_PX) and (min(a.y1, b.y1) - max(a.y0, b.y0) > TOLERANCE_PX)


def figure_problems(fig) -> list[str]:
    """What a reader cannot see in ``fig``: legends over data, overlapping labels (see module doc)."""
    if not hasattr(fig.canvas, "get_renderer"):  # a Figure made outside pyplot
        from matplotlib.backends.backend_agg import FigureCanvasAgg

        FigureCanvasAgg(fig)
    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()
    problems = []
    boxes = [("figure legend" if o is None else f"legend of axes {fig.axes.index(o)}", leg)
             for o, leg in _legends(fig) if leg.get_visible()]
    boxes += [(f"text '{t.get_text()[:30]}' of axes {i}", t) for i, ax in enumerate(fig.axes) for t in ax.texts
              if t.get_visible() and t.get_text().strip()]
    for where, artist in boxes:
        lb = artist.get_window_extent(renderer)
        for ax, label, xy in _points(fig):
            hit = (xy[:, 0] > lb.x0) & (xy[:, 0] < lb.x1) & (xy[:, 1] > lb.y0) & (xy[:, 1] < lb.y1)
            if hit.any():
                problems.append(f"{where} covers {int(hit.sum())} point(s) of '{label}' (axes {fig.axes.index(ax)})")
    problems += _hidden_lines(fig) + _labels_and_titles(fig)
    texts = _texts(fig, renderer)
    texts += [(f"legend of axes {fig.axes.index(o)}" if o is not None else "figure legend", leg.get_window_extent(renderer))
              for o, leg in _legends(fig) if leg.get_visible()]
    for (na, a), (nb, b) in itertools.combinations(texts, 2):
        if _overlap(a, b):
            problems.append(f"{na} overlaps {nb}")
    return problems


def _covers(a, b) -> bool:
    """Line ``b`` (drawn after ``a``) hides ``a`` where they coincide."""
    if b.get_alpha() not in (None, 1) or b.get_linestyle() not in ("-", "None", ""):
        return False
    if a.get_linestyle() not in ("None", "") and b.get_linestyle() in ("None", "") or b.get_linewidth() < a.get_linewidth():
        return False
    return a.get_marker() in (None, "None", "", " ") or b.get_markersize() >= a.get_markersize()


def _hidden_lines(fig) -> list[str]:
    out = []
    for i, ax in enumerate(fig.axes):
        lines = sorted([ln for ln in ax.get_lines() if ln.get_visible()], key=lambda ln: ln.get_zorder())
        xy = [ln.get_transform().transform(np.column_stack([np.asarray(ln.get_xdata(), float),
                                                            np.asarray(ln.get_ydata(), float)])) for ln in lines]
        for (j, a), (k, b) in itertools.combinations(enumerate(lines), 2):
            same = xy[j].shape == xy[k].shape and xy[j].size and np.allclose(xy[j], xy[k], atol=1.0, equal_nan=True)
            if same and _covers(a, b):
                out.append(f"axes {i}: line '{a.get_label()}' hidden under '{b.get_label()}'")
    return out


def _labels_and_titles(fig) -> list[str]:
    out = []
    for i, ax in enumerate(fig.axes):
        for axis in (ax.xaxis, ax.yaxis):
            text = axis.label.get_text()
            if len(re.findall(r"\([^()]*\)", text)) > 1:
                out.append(f"axes {i} {axis.axis_name} label {text!r} has more than one (...)")
    if not any(t.get_text().strip() for ax in fig.axes for t in (ax.title, ax._left_title, ax._right_title)) \
            and not (fig._suptitle is not None and fig._suptitle.get_text().strip()):
        out.append("no title")
    return out


def collect_figure_problems(monkeypatch) -> dict:
    """Check every figure saved from now on: ``{file name: problems}`` (filled as figures are saved)."""
    import os

    from matplotlib.figure import Figure

    found: dict = {}
    original = Figure.savefig

    def savefig(self, fname, *args, **kwargs):
        # save_figure writes to ".NAME.png.XXXX.part", renamed afterwards: name the figure by its final name
        name = re.sub(r"^\.(.*?\.png)\..*\.part$", r"\1", os.path.basename(str(fname)))
        found[name] = figure_problems(self)
        return original(self, fname, *args, **kwargs)

    monkeypatch.setattr(Figure, "savefig", savefig)
    return found
