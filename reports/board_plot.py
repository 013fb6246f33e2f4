"""``board_<name>.png``: an imported board face-on over its true outline, every part with its reference.

Two panels in the board's own (u, v) coordinates [mm] (the board file's x, y with y up): the top side, and
the bottom side seen through the board from the top (not mirrored, so a part lies where it lies in the
top view). Modelled parts are filled (dies red), parts merged into the board are outlined, the standoffs
under the board dashed; the model's board is shaded: the true outline's area where it closes (cut-outs and
slots left open, as the mesh has them), the rectangle (dotted) otherwise; sensor sites are marked. Each panel
names its outer copper layer's measured coverage, the title every layer's.
"""

from __future__ import annotations

import os
from collections import defaultdict

import matplotlib.pyplot as plt
import numpy as np
from matplotlib.patches import Rectangle

from imutherm.geometry.build import MM, Geometry
from imutherm.geometry.layout import AXES
from imutherm.geometry.outline import board_loops, cuts_board, inside

MODELLED, MERGED, DIE, STANDOFF, SITE = "#333333", "#7a9a88", "#c8402a", "#8a7a50", "#ff00aa"


def _local(board, lo, hi) -> tuple:
    """(u0, v0, u1, v1) [mm] of a global box (lo, hi) [m] in the board's (u, v) coordinates."""
    a0, a1 = (a for a in range(3) if a != AXES.index(board.normal))
    return ((lo[a0] / MM - board.min_mm[a0]), (lo[a1] / MM - board.min_mm[a1]),
            (hi[a0] / MM - board.min_mm[a0]), (hi[a1] / MM - board.min_mm[a1]))


def board_figure(geometry: Geometry, board_name: str):
    """The figure of board ``board_name`` of ``geometry`` (the caller saves and closes it)."""
    lay = geometry.layout
    board = next(b for b in lay.boards if b.name == board_name)
    axis = AXES.index(board.normal)
    a0, a1 = (a for a in range(3) if a != axis)
    w, h = board.size_mm[a0], board.size_mm[a1]
    face = {"top": (board.min_mm[axis] + board.size_mm[axis]) * MM, "bottom": board.min_mm[axis] * MM}
    fig, axes = plt.subplots(1, 2, figsize=(15, 7.6))
    comps = {c.name: c for c in lay.components if c.board == board_name}
    prefix = f"{board_name}_"
    label = lambda name: name[len(prefix):] if name.startswith(prefix) else name  # noqa: E731
    sites = defaultdict(list)
    for name, pos in geometry.sites.items():
        sites[tuple(round(float(v), 9) for v in pos)].append(name)
    shade = _board_shade(board, w, h)
    for ax, side in zip(axes, ("top", "bottom")):
        ax.add_patch(Rectangle((0, 0), w, h, fc="none", ec="#2e8b57", ls=":", lw=1.0, zorder=0))
        ax.imshow(shade, extent=(0, w, 0, h), origin="lower", interpolation="nearest", zorder=0)
        for line in board.outline_mm or ():
            us, vs = zip(*line)
            ax.plot(us, vs, color="k", lw=1.3, zorder=1)
        for m in board.merged_parts:
            if m.side != side:
                continue
            (cu, cv), (su, sv, _) = m.center_mm, m.size_mm
            ax.add_patch(Rectangle((cu - su / 2, cv - sv / 2), su, sv, fc="none", ec=MERGED, lw=0.7, zorder=2))
            ax.text(cu, cv, m.name, fontsize=4.2, ha="center", va="center", color="#2f4f3f", zorder=3)
        for p in geometry.parts:
            if p.kind == "box" and side == "bottom" and abs(p.hi[axis] - face["bottom"]) < 1e-9:
                u0, v0, u1, v1 = _local(board, p.lo, p.hi)
                if u1 > 0 and v1 > 0 and u0 < w and v0 < h:
                    ax.add_patch(Rectangle((u0, v0), u1 - u0, v1 - v0, fc="none", ec=STANDOFF, ls="--", lw=0.9,
                                           zorder=2))
            owner = p.parent if p.kind in ("die", "pad") else p.name
            if owner not in comps or p.kind not in ("component", "die"):
                continue
            on_top = p.hi[axis] > face["top"] - 1e-9 if p.kind == "component" else p.lo[axis] >= face["top"] - 1e-9
            if (side == "top") != on_top:
                continue
            u0, v0, u1, v1 = _local(board, p.lo, p.hi)
            if p.kind == "die":
                ax.add_patch(Rectangle((u0, v0), u1 - u0, v1 - v0, fc=DIE, ec="none", alpha=0.9, zorder=5))
                continue
            ax.add_patch(Rectangle((u0, v0), u1 - u0, v1 - v0, fc=MODELLED, ec="k", lw=0.5, alpha=0.8, zorder=4))
            ax.text((u0 + u1) / 2, v1, label(p.name), fontsize=6.5, ha="center", va="top", color="white", zorder=6,
                    bbox=dict(boxstyle="round,pad=0.1", fc="black", alpha=0.5, lw=0))
        for pos, names in sites.items():
            u0, v0, _, _ = _local(board, pos, pos)
            if not (0 <= u0 <= w and 0 <= v0 <= h):
                continue
            if (side == "top") != (pos[axis] >= face["top"] - 1e-9):
                continue
            ax.plot(u0, v0, marker="x", color=SITE, ms=7, zorder=7)
            text = names[0] if len(names) == 1 else f"{len(names)} sites: {', '.join(names)}"
            ax.annotate(text, (u0, v0), xytext=(8, -10), textcoords="offset points", fontsize=6, color="#b0007a",
                        zorder=7, bbox=dict(boxstyle="round,pad=0.1", fc="white", alpha=0.8, lw=0))
        ax.set_xlim(-1, w + 1)
        ax.set_ylim(-1, h + 1)
        ax.set_aspect("equal")
        ax.set_xlabel("u [mm]")
        ax.set_ylabel("v [mm]")
        n_mod = sum(1 for c in comps.values() if _side(c, lay, geometry) == side)
        n_mer = sum(1 for m in board.merged_parts if m.side == side)
        cov = board.copper_coverage
        copper = (f"; {'front' if side == 'top' else 'back'} copper {100 * cov[0 if side == 'top' else -1]:.0f} %"
                  if cov else "")
        ax.set_title(f"{side} side{' (seen from the top, through the board)' if side == 'bottom' else ''}: "
                     f"{n_mod} modelled, {n_mer} merged{copper}", fontsize=10)
    handles = [Rectangle((0, 0), 1, 1, fc=MODELLED, alpha=0.8, ec="k"), Rectangle((0, 0), 1, 1, fc=DIE),
               Rectangle((0, 0), 1, 1, fc="none", ec=MERGED), Rectangle((0, 0), 1, 1, fc="none", ec=STANDOFF, ls="--"),
               plt.Line2D([], [], color="k"), Rectangle((0, 0), 1, 1, fc="#2e8b57", alpha=0.18, ec="none"),
               Rectangle((0, 0), 1, 1, fc="none", ec="#2e8b57", ls=":")]
    fig.legend(handles, ["modelled part", "die", "merged into the board", "standoff", "true outline",
                         "the model's board", "its bounding rectangle"], loc="lower center", ncol=7, fontsize=8,
               frameon=False, bbox_to_anchor=(0.5, 0.0))
    src = board.source or "(no source file)"
    cov = board.copper_coverage
    copper = (f"; copper coverage measured, front to back: {', '.join(f'{100 * c:.0f} %' for c in cov)}" if cov
              else "")
    fig.suptitle(f"{lay.name}: board {board_name!r}, {w:.2f} x {h:.2f} x {board.size_mm[axis]:g} mm, scheme "
                 f"{geometry.scheme.name!r}{copper}\nfrom {src}", fontsize=10)
    fig.tight_layout(rect=(0, 0.06, 1, 0.93))
    return fig


def _board_shade(board, w: float, h: float, cell_mm: float = 0.1, max_cells: int = 1500):
    """An RGBA image over the board's rectangle: the model's board (what its closed outline fills, the
    rectangle when it does not close) shaded, the rest clear."""
    cell = max(cell_mm, max(w, h) / max_cells)
    us = (np.arange(max(1, int(np.ceil(w / cell)))) + 0.5) * cell
    vs = (np.arange(max(1, int(np.ceil(h / cell)))) + 0.5) * cell
    loops = board_loops(board.outline_mm)
    gu, gv = np.meshgrid(us, vs)   # rows along v (the image's y)
    fill = inside(loops, gu, gv) if loops and cuts_board(loops, w, h) else np.ones(gu.shape, bool)
    image = np.zeros(gu.shape + (4,))
    image[fill] = (0.18, 0.545, 0.341, 0.18)   # #2e8b57 at 18 %
    return image


def _side(comp, lay, geometry) -> str:
    """The side a component sits on in this scheme (moved to the back by the scheme, or as laid out)."""
    if comp.name in geometry.scheme.move_to_back:
        return "bottom" if comp.side == "top" else "top"
    return comp.side


def imported_boards(geometry: Geometry) -> list:
    """The names of the boards that carry a drawing's worth of import data (an outline or merged parts)."""
    return [b.name for b in geometry.layout.boards if b.outline_mm or b.merged_parts or b.source]


def plot_board(geometry: Geometry, board_name: str, path: str | os.PathLike) -> None:
    """Draw board ``board_name`` (see the module docstring) and save a PNG."""
    fig = board_figure(geometry, board_name)
    try:
        fig.savefig(path, dpi=150)
    finally:
        plt.close(fig)
