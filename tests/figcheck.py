"""A geometric check of a drawn figure: every text and legend inside the figure, no two labels on
top of each other, and no data axes squeezed below a readable size (issue 27: figures a designer
can put in a report).

The figure is drawn with the Agg canvas and each artist's window extent (pixels) is measured with
``artist.get_window_extent(renderer)``; nothing is compared with reference images.

Checked, with a small pixel tolerance:

* inside: the suptitle, figure texts, every axes' titles, axis labels, visible tick labels,
  annotations and texts, and every legend lie inside the figure's box;
* tick labels of one axis do not overlap each other;
* "labels" (titles, axis labels, annotations/texts of the axes and the figure, legends) do not
  overlap each other, nor the tick labels of any axes;
* data axes (not colour bars) are at least :data:`MIN_AXES_IN` inches in each direction;
* drawing raises no layout warning (constrained layout that could not fit the figure).
"""

from __future__ import annotations

import warnings
from itertools import combinations

from matplotlib.backends.backend_agg import FigureCanvasAgg

TOL_PX = 2.0  # pixels an extent may leave the figure, or two boxes may share
MIN_AXES_IN = 1.0  # smallest readable data axes, inches (width and height)


def _visible(artist, renderer=None) -> bool:
    """Drawn: visible, with text if it is a text, and an annotation whose point is not clipped away."""
    if artist is None or not artist.get_visible():
        return False
    if hasattr(artist, "get_text") and not artist.get_text().strip():
        return False
    return renderer is None or not hasattr(artist, "_check_xy") or artist._check_xy(renderer)


def _tick_labels(axis) -> list:
    """The tick labels that are drawn (ticks inside the view), both sides."""
    out = []
    for tick in axis._update_ticks():  # the ticks matplotlib draws: inside the view interval
        out += [lab for lab in (tick.label1, tick.label2) if _visible(lab)]
    return out


def _all_axes(fig) -> list:
    """Every axes of the figure, with their children (secondary axes)."""
    seen, out = set(), []
    for ax in fig.axes:
        for a in [ax, *getattr(ax, "child_axes", [])]:
            if id(a) not in seen:
                seen.add(id(a))
                out.append(a)
    return out


def _name(artist) -> str:
    text = artist.get_text() if hasattr(artist, "get_text") else type(artist).__name__
    return f"{type(artist).__name__} {text.splitlines()[0][:50]!r}" if text else type(artist).__name__


def collect(fig, renderer) -> tuple[list, dict]:
    """(labels, tick groups): labels as (name, bbox); tick groups {axis name: [(name, bbox)]}."""
    labels, ticks, seen = [], {}, set()

    def add(artist):
        if _visible(artist, renderer) and id(artist) not in seen:  # the suptitle is also one of fig.texts
            seen.add(id(artist))
            labels.append((_name(artist), artist.get_window_extent(renderer)))

    add(fig._suptitle)
    add(getattr(fig, "_supxlabel", None))
    add(getattr(fig, "_supylabel", None))
    for t in fig.texts:
        add(t)
    for leg in fig.legends:
        add(leg)
    for n, ax in enumerate(_all_axes(fig)):
        if not ax.get_visible():
            continue
        for t in (ax.title, ax._left_title, ax._right_title):
            add(t)
        for axis_name, axis in (("x", ax.xaxis), ("y", ax.yaxis)):
            add(axis.label)
            if axis.get_visible():
                ticks[f"axes {n} {axis_name}"] = [(_name(t), t.get_window_extent(renderer)) for t in _tick_labels(axis)]
        for t in ax.texts:
            add(t)
        add(ax.get_legend())
    return labels, ticks


def _overlap(a, b, tol: float) -> bool:
    return (min(a.x1, b.x1) - max(a.x0, b.x0) > tol) and (min(a.y1, b.y1) - max(a.y0, b.y0) > tol)


def problems(fig, tol: float = TOL_PX, min_axes_in: float = MIN_AXES_IN) -> list[str]:
    """Every geometric defect of ``fig`` as one line each; empty when the figure is clean."""
    canvas = fig.canvas if isinstance(fig.canvas, FigureCanvasAgg) else FigureCanvasAgg(fig)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        canvas.draw()
    renderer = canvas.get_renderer()
    out = [f"layout warning: {w.message}" for w in caught if "layout" in str(w.message).lower()]
    box = fig.bbox
    labels, ticks = collect(fig, renderer)
    everything = labels + [t for group in ticks.values() for t in group]
    for name, bb in everything:
        if bb.x0 < box.x0 - tol or bb.y0 < box.y0 - tol or bb.x1 > box.x1 + tol or bb.y1 > box.y1 + tol:
            out.append(f"outside the figure: {name} at x {bb.x0:.0f}..{bb.x1:.0f}, y {bb.y0:.0f}..{bb.y1:.0f} "
                       f"(figure {box.width:.0f} x {box.height:.0f} px)")
    for axis_name, group in ticks.items():
        for (na, a), (nb, b) in combinations(group, 2):
            if _overlap(a, b, tol):
                out.append(f"tick labels overlap on {axis_name}: {na} and {nb}")
    for (na, a), (nb, b) in combinations(labels, 2):
        if _overlap(a, b, tol):
            out.append(f"labels overlap: {na} and {nb}")
    for na, a in labels:
        for axis_name, group in ticks.items():
            for nb, b in group:
                if _overlap(a, b, tol):
                    out.append(f"label over a tick label of {axis_name}: {na} and {nb}")
    for ax in fig.axes:
        if ax.get_visible() and not hasattr(ax, "_colorbar"):
            bb = ax.get_window_extent(renderer)
            w, h = bb.width / fig.dpi, bb.height / fig.dpi
            if w < min_axes_in or h < min_axes_in:
                out.append(f"squeezed axes {ax.get_title() or ax.get_ylabel()!r}: {w:.2f} x {h:.2f} in")
    return out


def assert_clean(fig, what: str = "figure") -> None:
    """Raise AssertionError listing every defect of :func:`problems`."""
    found = problems(fig)
    assert not found, f"{what}:\n  " + "\n  ".join(found)
