"""Shared pieces of the figure modules: option defaults, axes layout, labels, case styles.

Option resolution turns what a user asked for (labels: degrees, rad/s, case names, 1-based
modes) into archive indices, with the defaults of each kind, and raises
:class:`~fkev_slepc.archive.reader.ArchiveError` with the CLI option name when a label is not there.
"""

from __future__ import annotations

import math
from typing import Sequence

import numpy as np
from matplotlib.figure import Figure

from fkev_slepc.scene.units import RAD_S_PER_RPM, with_rpm
from fkev_slepc.scene.cases import CASE_NAMES
from fkev_slepc.archive.reader import ArchiveError, SweepResults
from fkev_slepc.archive.scene_text import heading
from fkev_slepc.model.mechanism import node_displacement  # noqa: F401  (re-exported: plots.shapes, api.results)
from fkev_slepc.scene.model import mesh_label

SIMPLIFIED = ("no_coriolis", "no_tangential", "no_normal", "no_pseudo_normal")
PREFERRED_ANGLE_DEG = 10.0  # the thesis's detailed-study position (Figs 3.10-3.13, 3.22-3.25)
ANGLE_LABEL = "crank angle θ (deg)"
FREQ_LABEL = "natural frequency (Hz)"
SPEED_LABEL = "crank speed Ω (rad/s)"
CHAR_EM = 0.53  # mean character width in font sizes (DejaVu Sans text measures about 0.5): wraps with room to spare
ORDER_LABEL_GAP = 1.5  # crank-order labels at least this many font sizes apart (points)

# One look per case in every figure; `no_tangential` is dashed because it lies on `full`.
CASE_STYLE = {
    "structure": dict(color="0.45", ls=":", lw=1.6),
    "full": dict(color="k", ls="-", lw=2.4),
    "no_coriolis": dict(color="tab:green", ls="-", lw=1.4),
    "no_tangential": dict(color="tab:red", ls="--", lw=1.4),
    "no_normal": dict(color="tab:purple", ls="-", lw=1.4),
    "no_pseudo_normal": dict(color="tab:brown", ls="-.", lw=1.6),
}


# ------------------------------------------------------------------ option resolution
def default_case(res: SweepResults) -> str:
    """``full`` if the archive has it, else its first case (``SweepResults.default_case``)."""
    return res.default_case


def pick_angle(res: SweepResults, angle_deg: float | None) -> int:
    """Index of ``angle_deg``; default 10° (the thesis's study position) if on the grid,
    else the first angle."""
    if angle_deg is not None:
        return res.angle_index(angle_deg)
    try:
        return res.angle_index(PREFERRED_ANGLE_DEG)
    except ArchiveError:
        return 0


def pick_speed(res: SweepResults, speed: float | None) -> int:
    """Index of ``speed``; default the highest speed (where motion terms matter most)."""
    return res.speed_index(speed) if speed is not None else int(np.argmax(res.speed_rad_s))


def pick_cases(res: SweepResults, cases: Sequence[str | int] | None, default: Sequence[str]) -> list[int]:
    """Indices of ``cases`` (names or Table 3.1 numbers); else of the ``default`` names present."""
    if cases:
        return [res.case_index(c) for c in cases]
    idx = [res.cases.index(c) for c in default if c in res.cases]
    if not idx:
        raise ArchiveError(
            f"cases: none of {', '.join(default)} is in this archive (it has: {', '.join(res.cases)})"
        )
    return idx


def pick_modes(res: SweepResults, modes: Sequence[int] | None) -> list[int]:
    """Indices of 1-based ``modes``; default every archived mode."""
    return [res.mode_index(m) for m in modes] if modes else list(range(res.modes.size))


def only_one(values, option: str):
    """A single value from a list option (``angles=[10]``; ``--angle 10``), or a clear error naming ``option``."""
    if values is None or np.isscalar(values):
        return values
    values = list(values)
    if len(values) > 1:
        raise ArchiveError(f"{option}: this kind takes one value (got {', '.join(map(str, values))})")
    return values[0] if values else None


# --------------------------------------------------------------------- layout, labels
def mode_grid(n_axes: int, width: float = 10.0, height: float = 3.4) -> tuple[Figure, list]:
    """A figure with one axes per mode: one column for 1 mode, two columns otherwise."""
    ncols = 1 if n_axes == 1 else 2
    nrows = math.ceil(n_axes / ncols)
    size = (width if ncols > 1 else 0.62 * width, 0.9 + height * nrows)
    fig = Figure(figsize=size, layout="constrained")
    axes = fig.subplots(nrows, ncols, squeeze=False).ravel()
    for ax in axes[n_axes:]:
        ax.remove()  # an odd mode count leaves one cell empty
    return fig, list(axes[:n_axes])


def angle_axis(ax) -> None:
    """Crank-angle x axis over one cycle, ticks every 60°."""
    ax.set_xlabel(ANGLE_LABEL)
    ax.set_xlim(0, 360)
    ax.set_xticks(np.arange(0, 361, 60))


def case_style(name: str) -> dict:
    """Line style of a case (colour, dash, width); empty for unknown names."""
    return dict(CASE_STYLE.get(name, {}))


def speed_label(omega: float, rpm: bool = False) -> str:
    """``Ω = 628.319 rad/s``, with ``(6000 rpm)`` when the run's speeds were given in rpm."""
    return "Ω = " + with_rpm(omega, rpm)


def rpm_axis(ax, which: str = "x") -> None:
    """A secondary speed axis in rev/min (top or right) beside the rad/s one."""
    convert = (lambda w: w / RAD_S_PER_RPM, lambda n: n * RAD_S_PER_RPM)
    if which == "x":
        ax.secondary_xaxis("top", functions=convert).set_xlabel("crank speed (rpm)")
    else:
        ax.secondary_yaxis("right", functions=convert).set_ylabel("crank speed (rpm)")


def case_label(name: str) -> str:
    """Case name with its Table 3.1 number, e.g. ``no_normal (4)``."""
    return f"{name} ({CASE_NAMES.index(name)})" if name in CASE_NAMES else name


def elements_tag(res: SweepResults) -> str:
    """``9 el (3+3+3)``: the mesh of an archive."""
    el = res.elements_per_link()
    return mesh_label(el) if el else res.path.stem


def scene_heading(res: SweepResults) -> str:
    """The scene's title, plus the mesh when the run re-meshed the scene (``--elements``),
    and a warning when the archive is still being written (or was killed: ``--resume``)."""
    head = heading(res.title, res.elements_per_link(), res.scene_toml)
    if int(res.attrs.get("complete", 1)) == 0:
        head += " [incomplete archive]"
    return head


def set_title(fig: Figure, res: SweepResults, what: str) -> None:
    """Two-line figure title: the scene, then what the figure shows (wrapped to the figure)."""
    suptitle(fig, f"{scene_heading(res)}\n{what}")


def suptitle(fig: Figure, text: str, fontsize: float = 11):
    """The figure's title, each line wrapped to the figure's width (:func:`fit_width`)."""
    return fig.suptitle(fit_width(text, 0.97 * fig.get_figwidth(), fontsize), fontsize=fontsize)


def fit_width(text: str, width_in: float, fontsize: float) -> str:
    """``text`` with every line longer than ``width_in`` inches at ``fontsize`` points broken:
    between clauses ("; ") first, then list items (", "), then words, so that a title's phrases
    stay whole where they fit.

    Examples
    --------
    >>> print(fit_width("stability map, case full; 3 unstable, 1 divergent of 63 points", 2.2, 10))
    stability map, case full;
    3 unstable, 1 divergent of
    63 points
    """
    n = max(24, int(width_in * 72 / (CHAR_EM * fontsize)))
    return "\n".join(_fit_line(line, n, ("; ", ", ", " ")) for line in text.split("\n"))


def _fit_line(line: str, n: int, seps: tuple[str, ...]) -> str:
    """``line`` broken at ``seps[0]`` into lines of at most ``n`` characters where it can,
    pieces still too long broken at the next separator."""
    if len(line) <= n or not seps:
        return line
    parts = line.split(seps[0])
    end = seps[0].rstrip()  # kept at the end of a broken line ("; " -> ";")
    out, cur = [], ""
    for i, part in enumerate(parts):
        piece = part + (end if i < len(parts) - 1 else "")
        if cur and len(cur) + 1 + len(piece) > n:
            out.append(cur)
            cur = piece
        else:
            cur = f"{cur} {piece}" if cur else piece
    out.append(cur)
    return "\n".join(_fit_line(x, n, seps[1:]) for x in out)


def label_orders(ax, x: float, orders: int, top: float, fontsize: float = 7, color: str = "0.4") -> None:
    """Label the crank-order lines k·Ω/2π (Hz) at speed ``x`` with ``k×``: those below ``top``
    (the y limit), every step-th (1, 2, 5, 10, ...) so that labels stand ORDER_LABEL_GAP font
    sizes apart on axes about the figure's height less 1.4 in of titles and labels."""
    if not (x > 0 and top > 0 and math.isfinite(x * top)):
        return
    spacing = x / (2 * math.pi) / top * max(ax.figure.get_figheight() - 1.4, 1.0) * 72  # points between lines
    step = 1
    while step * spacing < ORDER_LABEL_GAP * fontsize:
        step = step * 5 // 2 if str(step)[0] == "2" else 2 * step  # 1, 2, 5, 10, 20, 50, ...
    for k in [1] if step > orders else range(step, orders + 1, step):
        if k * x / (2 * math.pi) <= top:
            ax.annotate(f"{k}×", (x, k * x / (2 * math.pi)), fontsize=fontsize, color=color, xytext=(2, 0),
                        textcoords="offset points", va="center")


def edges(centers: np.ndarray) -> np.ndarray:
    """Cell edges around grid centres: the midpoints, and the first and last centres themselves
    (the end cells are half cells), so that a map covers exactly the computed range; a single
    centre gets a cell of its own size around it.

    Examples
    --------
    >>> edges([0.0, 150.0]), edges([0.0, 10.0, 20.0])
    (array([  0.,  75., 150.]), array([ 0.,  5., 15., 20.]))
    """
    c = np.asarray(centers, dtype=float)
    if c.size == 1:
        h = 0.5 * (abs(c[0]) or 1.0)
        return np.array([c[0] - h, c[0] + h])
    return np.concatenate([[c[0]], 0.5 * (c[1:] + c[:-1]), [c[-1]]])


def legend_outside(ax, where: str = "right", **options):
    """The legend beside (``"right"``) or below (``"below"``) the axes, never over the data."""
    if where == "below":
        return ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.16), borderaxespad=0, **options)
    return ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0, **options)


def align_phase(x: np.ndarray, ref: np.ndarray | None) -> np.ndarray:
    """``x`` times a unit phase factor, so that its real part is the shape to draw.

    With no reference: the phase that maximizes ‖Re x‖ (ψ = ½ arg Σx²). With a reference:
    the phase that best matches it (ψ = arg refᴴx), so the cases of one mode are drawn in
    the same sense. Real shapes (no Coriolis term) come back real up to sign.
    """
    if ref is None:
        s = np.sum(x * x)
        psi = 0.5 * np.angle(s) if abs(s) > 0 else 0.0
    else:
        psi = np.angle(np.vdot(ref, x))
    return x * np.exp(-1j * psi)
