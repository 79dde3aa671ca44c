"""A DH table as a boxed text table: :func:`format_dh_table`, also ``str(table)``.

Angles print in degrees and lengths in metres, six significant digits
(:func:`manipkit.text.short_text`), float noise (below ``NOISE`` of the
value's scale) as 0; the conventions are those of
:mod:`manipkit.dh.table` (docs/architecture.md).
"""

from __future__ import annotations

import math
import re
from typing import TYPE_CHECKING

import numpy as np

from manipkit.text import short_text

if TYPE_CHECKING:  # the table's types name the arguments only: dh.table imports this module to print itself
    from manipkit.dh.table import DHRow, DHTable

__all__ = ["NOISE", "format_dh_table", "html_dh_table", "latex_dh_table"]

#: Printed numbers within this of zero, relative to their scale (1 rad for angles, the table's largest
#: length for lengths), are rounding noise of a derivation and print as 0; so is a pitch this close to
#: +-90 deg (gimbal lock, roll then 0).
NOISE = 1e-9

_BOX = {"top": "┌┬┐", "mid": "├┼┤", "bottom": "└┴┘"}
_HEADERS = {
    "standard": ["j", "θⱼ", "dⱼ", "aⱼ", "αⱼ", "q limits"],
    "modified": ["j", "aⱼ₋₁", "αⱼ₋₁", "θⱼ", "dⱼ", "q limits"],
}


def format_dh_table(table: DHTable) -> str:
    """A DH table as a boxed text table (also ``str(table)``).

    The heading names the table, the convention (``standard DH`` or
    ``modified DH``), the joint count and kinds (R revolute, P prismatic).
    Columns, standard DH: ``j, θⱼ, dⱼ, aⱼ, αⱼ, q limits``; modified DH:
    ``j, aⱼ₋₁, αⱼ₋₁, θⱼ, dⱼ, q limits``. The joint variable ``qj`` appears in
    the ``θ`` column of a revolute row and in the ``d`` column of a
    prismatic row, with the row's offset (``q2 + 180°``). Angles are in
    degrees, lengths in metres, six significant digits. A base or tool that
    is not the identity is printed below the table as ``xyz`` (m) and
    ``rpy`` (deg, ``R = Rz(yaw) Ry(pitch) Rx(roll)``).

    Parameters
    ----------
    table : DHTable

    Returns
    -------
    str

    Examples
    --------
    >>> from manipkit.dh.table import DHRow, DHTable
    >>> print(format_dh_table(DHTable([DHRow(1, 0, 0, 0), DHRow(1, 0, 0, np.pi / 2)], "standard", "planar_2r")))
    planar_2r: standard DH, 2 joints (RR)
    ┌───┬──────────┬────┬────┬────┬──────────┐
    │ j │ θⱼ       │ dⱼ │ aⱼ │ αⱼ │ q limits │
    ├───┼──────────┼────┼────┼────┼──────────┤
    │ 1 │ q1       │  0 │  1 │ 0° │        - │
    │ 2 │ q2 + 90° │  0 │  1 │ 0° │        - │
    └───┴──────────┴────┴────┴────┴──────────┘
    """
    title, header, body, placements = _table_cells(table)
    # the joint variable's column and names read left-aligned, numbers right-aligned
    left = {0, header.index("θⱼ")}
    if "joint" in header:
        left = {0, 1} | {k for k in left if k > 0}
    return "\n".join([title, *_boxed(header, body, left), *placements])


def _table_cells(table: DHTable) -> tuple[str, list[str], list[list[str]], list[str]]:
    """(title, header, body cells, base/tool lines) of the printout, shared by text, HTML and LaTeX."""
    header = list(_HEADERS[table.convention])
    length = _length_text(table)
    body = [_row_cells(row, j, table.convention, length) for j, row in enumerate(table.rows, start=1)]
    if any(row.name for row in table.rows):
        header.insert(1, "joint")
        for cells, row in zip(body, table.rows):
            cells.insert(1, row.name or "-")
    kinds = "".join("R" if row.is_revolute else "P" for row in table.rows)
    title = f"{table.convention} DH, {table.n} joint{'s' if table.n != 1 else ''} ({kinds})"
    title = f"{table.name}: {title}" if table.name else title
    placements = []
    for what in ("base", "tool"):
        if not np.array_equal(getattr(table, what), np.eye(4)):
            xyz, rpy = table.placement_xyz_rpy(what, check=False, gimbal_tol=NOISE)
            locked = abs(abs(rpy[1]) - math.pi / 2) <= NOISE
            placements.append(
                f"{what}: xyz = [{', '.join(length(v) for v in xyz)}] m, "
                f"rpy = [{', '.join(_degrees_text(v) for v in rpy)}] (R = Rz(yaw) Ry(pitch) Rx(roll)"
                + ("; gimbal lock: only yaw " + ("-" if rpy[1] > 0 else "+") + " roll is defined, roll set to 0)"
                   if locked else ")")
            )
    return title, header, body, placements


def html_dh_table(table: DHTable) -> str:
    """The table as HTML (``DHTable._repr_html_``, what Jupyter shows): a caption and one row per joint.

    The same cells as :func:`format_dh_table`; every text is HTML-escaped.

    >>> from manipkit.dh.table import DHRow, DHTable
    >>> print(html_dh_table(DHTable([DHRow(1, 0, 0, 0)], "standard", "a<b")).splitlines()[1])
    <caption style="text-align: left">a&lt;b: standard DH, 1 joint (R)</caption>
    """
    from html import escape

    title, header, body, placements = _table_cells(table)
    lines = ['<table class="manipkit-dh">', f'<caption style="text-align: left">{escape(title)}</caption>',
             "<tr>" + "".join(f"<th>{escape(h)}</th>" for h in header) + "</tr>"]
    lines += ["<tr>" + "".join(f'<td style="text-align: right">{escape(c)}</td>' for c in cells) + "</tr>" for cells in body]
    lines.append("</table>")
    lines += [f"<div>{escape(p)}</div>" for p in placements]
    return "\n".join(lines)


_LATEX_SPECIAL = {c: "\\" + c for c in "#$%&_{}"} | {"~": r"\textasciitilde{}", "^": r"\textasciicircum{}",
                                                     "\\": r"\textbackslash{}"}
_LATEX_HEADERS = {
    "j": "j", "joint": r"\text{joint}", "θⱼ": r"\theta_j", "dⱼ": "d_j", "aⱼ": "a_j", "αⱼ": r"\alpha_j",
    "aⱼ₋₁": "a_{j-1}", "αⱼ₋₁": r"\alpha_{j-1}", "q limits": r"q\ \text{limits}",
}


def latex_dh_table(table: DHTable) -> str:
    r"""The table as LaTeX math (``DHTable._repr_latex_``): ``$$\begin{array}...\end{array}$$``.

    Joint variables read ``q_{2} + 90^\circ``; names are set as escaped ``\text{}``.

    >>> from manipkit.dh.table import DHRow, DHTable
    >>> print(latex_dh_table(DHTable([DHRow(1, 0, 0, 0)], "standard")).splitlines()[2])
    j & \theta_j & d_j & a_j & \alpha_j & q\ \text{limits} \\ \hline
    """
    title, header, body, placements = _table_cells(table)

    def text(value: str) -> str:
        return r"\text{" + "".join(_LATEX_SPECIAL.get(c, c) for c in value) + "}"

    def cell(value: str, column: str) -> str:
        if column == "joint":
            return text(value)
        value = re.sub(r"q(\d+)", r"q_{\1}", value).replace("°", r"^\circ")
        return value.replace(" m", r"\ \text{m}")

    span = r"\multicolumn{" + str(len(header)) + "}{l}"
    lines = ["$$", r"\begin{array}{" + "r" * len(header) + "} " + span + "{" + text(title) + r"} \\",
             " & ".join(_LATEX_HEADERS[h] for h in header) + r" \\ \hline"]
    lines += [" & ".join(cell(c, h) for c, h in zip(cells, header)) + r" \\" for cells in body]
    lines += [span + "{" + text(p) + r"} \\" for p in placements]
    lines += [r"\end{array}", "$$"]
    return "\n".join(lines)


def _length_text(table: DHTable):
    """``short_text`` for the table's lengths, with |x| below ``NOISE`` times its largest length printed as 0."""
    lengths = [abs(v) for row in table.rows for v in (row.a, row.d)]
    lengths += [float(np.abs(T[:3, 3]).max()) for T in (table.base, table.tool)]
    finite = [v for v in lengths if math.isfinite(v)]
    zero = NOISE * max(finite, default=0.0)
    return lambda value: short_text(value, zero=zero)


def _row_cells(row: DHRow, j: int, convention: str, length=short_text) -> list[str]:
    """The cells of row ``j`` (1-based) in the column order of ``_HEADERS[convention]``."""
    variable = f"q{j}"
    if row.is_revolute:
        theta, d = _with_variable(variable, _degrees_number(row.theta), "°"), length(row.d)
    else:
        theta, d = _degrees_text(row.theta), _with_variable(variable, length(row.d), "")
    if row.qlim is None:
        limits = "-"
    elif row.is_revolute:
        limits = f"[{_degrees_text(row.qlim[0])}, {_degrees_text(row.qlim[1])}]"
    else:
        limits = f"[{short_text(row.qlim[0])}, {short_text(row.qlim[1])}] m"
    if convention == "standard":
        return [str(j), theta, d, length(row.a), _degrees_text(row.alpha), limits]
    return [str(j), length(row.a), _degrees_text(row.alpha), theta, d, limits]


def _degrees_number(radians: float) -> str:
    """Degrees, six digits; an angle within ``NOISE`` rad of 0 prints as 0."""
    return short_text(math.degrees(radians), zero=math.degrees(NOISE))


def _degrees_text(radians: float) -> str:
    return _degrees_number(radians) + "°"


def _with_variable(variable: str, offset_text: str, unit: str) -> str:
    """``q2``, ``q2 + 90°`` or ``q2 - 90°``: the joint variable plus the row's offset."""
    if offset_text == "0":
        return variable
    if offset_text.startswith("-"):
        return f"{variable} - {offset_text[1:]}{unit}"
    return f"{variable} + {offset_text}{unit}"


def _boxed(header: list[str], body: list[list[str]], left: set[int]) -> list[str]:
    """The lines of a box-drawn table; columns in ``left`` are left-aligned, the others right-aligned."""
    widths = [max(len(cells[k]) for cells in [header] + body) for k in range(len(header))]

    def rule(kind: str) -> str:
        first, middle, last = _BOX[kind]
        return first + middle.join("─" * (w + 2) for w in widths) + last

    def cells_line(cells: list[str], is_header: bool = False) -> str:
        parts = [
            c.ljust(w) if (is_header or k in left) else c.rjust(w)
            for k, (c, w) in enumerate(zip(cells, widths))
        ]
        return "│ " + " │ ".join(parts) + " │"

    return [rule("top"), cells_line(header, True), rule("mid"), *(cells_line(c) for c in body), rule("bottom")]
