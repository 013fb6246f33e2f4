"""The parts an imported unit's grease scheme bonds to the base, of those chosen: where each can be bonded.

Which parts are chosen is the thermal model's question (:mod:`imutherm.unit.grease_choice`, passed in as
``ImportOptions.grease_rule`` by ``imutherm import``); ``--grease`` names them; without either (the ecad layer
alone, no thermal model), :func:`dissipators` takes those carrying 10 % of the power and at least 0.05 W.
"""

from __future__ import annotations

#: the ecad layer's own choice without a thermal model: a part is a dissipator to bond at 10 % of the board's
#: total and at least this [W] (the reference unit's grease scheme moves its 0.24-0.9 W chips, not its 0.04 W ADC)
GREASE_MIN_W = 0.05


def dissipators(decisions: list) -> tuple:
    """The refs of the modelled parts carrying >= 10 % of the power and >= :data:`GREASE_MIN_W`."""
    modelled = [d for d in decisions if d.fate == "modelled"]
    total = sum(d.power_W for d in modelled)
    return tuple(d.footprint.ref for d in modelled if d.power_W >= max(GREASE_MIN_W, 0.1 * total))


def grease_parts(decisions: list, opts, standoffs: list, notes: list, chosen_refs) -> list:
    """The parts the grease scheme bonds to the base, of ``chosen_refs``: top-side ones moved to the back where their
    footprint is free there (no part, no standoff), bottom-side ones where they are (no standoff under them).
    Each part left out is said in ``notes`` with its reason and ``--grease``."""
    from imutherm import InputError
    from imutherm.ecad.part_bodies import overlaps

    modelled = [d for d in decisions if d.fate == "modelled"]
    chosen = [d for d in modelled if d.footprint.ref in chosen_refs]
    if opts.grease is not None:
        missing = set(opts.grease) - {d.footprint.ref for d in chosen}
        if missing:
            raise InputError(f"--grease: {', '.join(sorted(missing))} is not a modelled part (merged or skipped)")
    out = []
    for d in chosen:
        bottom = d.footprint.side != "top"
        clash = [] if bottom else [o.footprint.ref for o in decisions if o.fate in ("modelled", "merged")
                                   and o.footprint.side == "bottom" and overlaps(o.body, d.body)]
        clash += [f"the standoff under {ref}" for ref, r in standoffs if overlaps(r, d.body)]
        if clash:
            notes.append(f"grease scheme: {d.footprint.ref} cannot be bonded: "
                         + (f"the base under it holds {', '.join(clash[:4])}" if bottom else
                            f"{d.footprint.ref} stays on top: its back-side footprint holds {', '.join(clash[:4])}")
                         + " (--grease REF,... bonds others)")
            continue
        out.append(d)
    return out
