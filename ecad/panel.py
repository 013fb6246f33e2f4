"""Which board of the file is modelled: one board, a board with parts left outside it, or a panel.

A board file may hold more than the board: parts left beside it in the editor, or a panel (several boards,
or copies of one, joined by breakaway tabs to each other and to a frame). :func:`pick_board` finds the board
pieces of the outline and returns the one board to model, every footprint that is not on it marked
``off_board`` with its reason (the import skips it and says why):

1. the ``Edge.Cuts`` outline is joined into closed loops and filled by the even-odd rule on a raster of
   about :data:`RASTER_CELLS` cells along the longer side (cut-outs and slots stay open);
2. the panel's breakaway lines are cut: around every bare hole of less than a mounting hole (the mouse bites
   a panel tool drills along a tab, a footprint of holes only) and every small closed loop of the outline,
   :data:`BITE_CLEARANCE_MM` more is cleared, so a row of bites (spaced at most the hole plus twice that)
   parts the tab;
3. the connected pieces are the boards and the frame; each footprint belongs to the piece its outline
   (fab, courtyard, pads) covers most; a piece whose footprints are only holes, fiducials and logos is the
   frame;
4. one board piece is modelled: the one holding the ``--site`` parts (then the ``--power`` parts; of copies, the
   top left one), else the one with the most parts. Its outline
   rectangle becomes the board's (origin at its lower left); the others' footprints are skipped: "on another
   board of the panel", "on the panel's frame", or "outside the board outline".

V-scored panels (boards joined edge to edge, no gap) are one piece here; their copies' parts overlap nothing,
so they import as one board, which the note on repeated references says. An outline that does not close is
taken as its bounding rectangle, as before.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from imutherm.ecad.board import BoardDesign, Footprint, Rect
from imutherm.ecad.classify import hole_only, skip_reason
from imutherm.ecad.outline_loops import chain, inside, loop_area

#: raster cells along the board's longer side (0.1 mm on a 100 mm board), between these sizes [mm]
RASTER_CELLS = 1000
RASTER_MM = (0.05, 0.5)
#: cleared around each mouse bite beyond its hole [mm]: KiKit spaces bites of 0.3-0.5 mm up to 1 mm apart
#: (its documented defaults: drill 0.5 mm, spacing 0.8-1 mm, offset 0.25 mm)
BITE_CLEARANCE_MM = 0.5
#: a closed loop of the outline smaller than this [mm^2] is a drilled hole (a bite), not a cut-out
BITE_LOOP_MM2 = math.pi * 1.0 ** 2
#: pieces smaller than this [mm^2] are raster specks, not boards
MIN_PIECE_MM2 = 1.0


def _fp_box(fp: Footprint) -> Rect:
    """A footprint's extent in board coordinates (fab, courtyard and pads; its origin if it has none)."""
    pts = []
    for r in [fp.fab, fp.courtyard] + [p.rect for p in fp.pads]:
        if r is not None:
            pts += [fp.to_board(x, y) for x in (r.x0, r.x1) for y in (r.y0, r.y1)]
    return Rect.around(pts) if pts else Rect(fp.x, fp.y, fp.x, fp.y)


def _raster(board: BoardDesign, loops: list) -> tuple:
    """(filled raster, cell size [mm], x0, y0 of cell (0, 0) centre): the loops filled, bites cleared."""
    r = min(max(max(board.width_mm, board.height_mm) / RASTER_CELLS, RASTER_MM[0]), RASTER_MM[1])
    nx, ny = int(math.ceil(board.width_mm / r)) + 1, int(math.ceil(board.height_mm / r)) + 1
    xs, ys = np.arange(nx) * r, np.arange(ny) * r
    fill = np.zeros((ny, nx), bool)
    bites = []
    for loop in loops:
        box = Rect.around(loop)
        if loop_area(loop) < BITE_LOOP_MM2:
            bites.append((*box.centre, 0.5 * max(box.width, box.height)))
        i0, i1 = np.searchsorted(xs, box.x0), np.searchsorted(xs, box.x1, "right")
        j0, j1 = np.searchsorted(ys, box.y0), np.searchsorted(ys, box.y1, "right")
        if i1 > i0 and j1 > j0:
            gx, gy = np.meshgrid(xs[i0:i1], ys[j0:j1])
            fill[j0:j1, i0:i1] ^= inside([loop], gx, gy)
    for fp in board.footprints:
        why = hole_only(fp)
        if why and why.startswith("bare hole"):
            for p in fp.pads:
                if p.drill_mm:
                    bites.append((*fp.to_board(*p.rect.centre), 0.5 * p.drill_mm))
    for x, y, rad in bites:
        rr = rad + BITE_CLEARANCE_MM
        i0, i1 = np.searchsorted(xs, x - rr), np.searchsorted(xs, x + rr, "right")
        j0, j1 = np.searchsorted(ys, y - rr), np.searchsorted(ys, y + rr, "right")
        gx, gy = np.meshgrid(xs[i0:i1], ys[j0:j1])
        fill[j0:j1, i0:i1] &= (gx - x) ** 2 + (gy - y) ** 2 > rr * rr
    return fill, r


def _cover(labels: np.ndarray, r: float, box: Rect) -> dict:
    """{piece label: cells of it under ``box``}."""
    ny, nx = labels.shape
    i0, i1 = max(int(math.floor(box.x0 / r)), 0), min(int(math.ceil(box.x1 / r)) + 1, nx)
    j0, j1 = max(int(math.floor(box.y0 / r)), 0), min(int(math.ceil(box.y1 / r)) + 1, ny)
    if i1 <= i0 or j1 <= j0:
        return {}
    values, counts = np.unique(labels[j0:j1, i0:i1], return_counts=True)
    return {int(v): int(c) for v, c in zip(values, counts) if v > 0}


def pick_board(board: BoardDesign, sites=(), powered=()) -> BoardDesign:
    """The board to model of ``board``'s file (see the module docstring): the same BoardDesign when the file
    holds one board and nothing outside it, else the chosen board with the rest marked ``off_board``.

    sites, powered : references the user named (``--site``, ``--power``); the board holding them is chosen."""
    from scipy.ndimage import find_objects, label

    loops, _ = chain(board.outline)
    unclosed = "the board outline does not close into a loop: its bounding rectangle is taken as the board"
    if not loops:
        return replace(board, notes=board.notes + (unclosed,))
    fill, r = _raster(board, loops)
    labels, n = label(fill)
    sizes = np.bincount(labels.ravel(), minlength=n + 1) * r * r
    pieces = [k for k in range(1, n + 1) if sizes[k] >= MIN_PIECE_MM2]
    owner = {}
    for i, fp in enumerate(board.footprints):
        cover = {k: c for k, c in _cover(labels, r, _fp_box(fp)).items() if k in pieces}
        owner[i] = max(cover, key=cover.get) if cover else 0
    physical = [i for i, fp in enumerate(board.footprints) if skip_reason(fp) is None]
    if physical and sum(owner[i] > 0 for i in physical) < 0.5 * len(physical):
        # the closed loops do not hold the parts (an outer edge with a gap, only its holes closing)
        return replace(board, notes=board.notes + (unclosed,))
    parts = {k: [i for i in physical if owner[i] == k] for k in pieces}
    boards = [k for k in pieces if parts[k]] or pieces[:1]
    extent = find_objects(labels)
    top_left = {k: (round(extent[k - 1][0].stop * r), -round(extent[k - 1][1].start * r)) for k in boards}
    chosen = max(boards, key=lambda k: (len(_holds(board, owner, k, sites)), len(_holds(board, owner, k, powered)),
                                        0 if sites or powered else len(parts[k]), top_left[k]))
    frame = [k for k in pieces if k not in boards]
    notes = list(board.notes)
    if len(boards) > 1 or frame:
        ys, xs = extent[chosen - 1]
        why = ("holding the --site part" if _holds(board, owner, chosen, sites) else
               "holding the --power parts" if _holds(board, owner, chosen, powered) else "the one with the most parts")
        plural = "s" if len(frame) > 1 else ""
        notes.append(f"the file holds {len(boards)} board{'s' if len(boards) > 1 else ''}"
                     + (f" and a frame ({len(frame)} piece{plural} without parts)" if frame else "")
                     + f", joined by tabs or mouse bites: modelled the board at {xs.start * r:.1f}..{xs.stop * r:.1f}"
                     f" x {ys.start * r:.1f}..{ys.stop * r:.1f} mm of the file ({why}); the footprints of the rest "
                     f"are skipped (to model another board, give --site on one of its parts)")
    footprints = []
    for i, fp in enumerate(board.footprints):
        k = owner[i]
        why = ("" if k == chosen else "outside the board outline" if k == 0 else
               "on the panel's frame" if k in frame else "on another board of the panel")
        footprints.append(replace(fp, off_board=why) if why and not fp.off_board else fp)
    if len(boards) == 1 and not frame:
        return replace(board, footprints=tuple(footprints), notes=tuple(notes))
    return _crop(replace(board, footprints=tuple(footprints), notes=tuple(notes)), labels == chosen, r)


def _holds(board, owner, piece, refs):
    return [i for i, o in owner.items() if o == piece and board.footprints[i].ref in set(refs)]


def _crop(board: BoardDesign, mask: np.ndarray, r: float) -> BoardDesign:
    """``board`` cut to the piece ``mask``: its outline rectangle (origin at its lower left), the outline
    polylines within it, every point shifted."""
    j, i = np.nonzero(mask)
    pts = [p for line in board.outline for p in line
           if i.min() * r - 2 * r <= p[0] <= i.max() * r + 2 * r and j.min() * r - 2 * r <= p[1] <= j.max() * r + 2 * r]
    box = Rect.around(pts) or Rect(i.min() * r, j.min() * r, i.max() * r, j.max() * r)

    def keep(p):
        return box.x0 - 1e-6 <= p[0] <= box.x1 + 1e-6 and box.y0 - 1e-6 <= p[1] <= box.y1 + 1e-6

    def move(p):
        return (round(p[0] - box.x0, 6), round(p[1] - box.y0, 6))

    outline = []
    for line in board.outline:
        run = []
        for p in list(line) + [None]:
            if p is not None and keep(p):
                run.append(move(p))
            elif run:
                if len(run) >= 2:
                    outline.append(tuple(run))
                run = []
    footprints = tuple(replace(fp, x=round(fp.x - box.x0, 6), y=round(fp.y - box.y0, 6)) for fp in board.footprints)
    vias = tuple(replace(v, x=v.x - box.x0, y=v.y - box.y0) for v in board.vias if keep((v.x, v.y)))
    return replace(board, width_mm=box.width, height_mm=box.height, outline=tuple(outline), footprints=footprints,
                   vias=vias, copper=tuple(layer.shifted(-box.x0, -box.y0) for layer in board.copper))


def unique_references(board: BoardDesign) -> tuple:
    """(board, note): the footprints on the board given unique references, a repeat of ``U4`` becoming
    ``U4_2`` (``U4_3`` ...); the note names what repeats, or is "" when nothing does. KiCad leaves references
    repeated on unannotated parts (``REF**``, ``R?``) and on a panel's copies."""
    seen, taken, repeats = {}, {fp.ref for fp in board.footprints}, {}
    footprints = []
    for fp in board.footprints:
        if fp.off_board:
            footprints.append(fp)
            continue
        k = seen.get(fp.ref, 0) + 1
        seen[fp.ref] = k
        if k == 1:
            footprints.append(fp)
            continue
        name, n = f"{fp.ref}_{k}", k
        while name in taken:
            n += 1
            name = f"{fp.ref}_{n}"
        taken.add(name)
        repeats[fp.ref] = repeats.get(fp.ref, 0) + 1
        footprints.append(replace(fp, ref=name))
    if not repeats:
        return board, ""
    listed = ", ".join(f"{ref} ({n + 1} footprints)" for ref, n in list(repeats.items())[:8])
    return (replace(board, footprints=tuple(footprints)),
            f"duplicate references on the board: {listed}{' ...' if len(repeats) > 8 else ''}; the repeats are told "
            f"apart as {next(iter(repeats))}_2, ... (annotate the board in KiCad to name them)")
