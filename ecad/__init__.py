"""Boards from ECAD files (KiCad ``.kicad_pcb``, IDF v3 ``.emn``/``.emp``) into layouts.

A reader turns a board file into a neutral :class:`~imutherm.ecad.board.BoardDesign`;
:mod:`imutherm.ecad.to_layout` turns that into the same layout (TOML) a hand-written unit has, so nothing
below the layout knows where a board came from. The package heights (:mod:`imutherm.ecad.packages`),
the board's conductivity rule (:mod:`imutherm.geometry.board_material`) and the merge rules
(:mod:`imutherm.ecad.classify`) are data with sources, each in its own module.
"""
