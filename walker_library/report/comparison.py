"""Our numbers beside the published ones, for the report's comparison table.

:data:`REFERENCES` holds, per walker model, the publication (cited in full), the parameter values
its numbers were computed at, and one :class:`Reference` per number: where it is printed, the
value as printed (its last digit gives its rounding), an extra uncertainty where one can be
stated (a grid step, a model limit), one sentence on why ours may differ, and the section of
REPRODUCTION.md or docs/walkers.md that discusses it. :func:`compare` makes the rows:
ours, the deviation, the tolerance (the published rounding plus the stated uncertainty) and
whether the two agree within it. A run at other parameter values than the publication's gets no
rows, and :func:`compare` says which values differ.
"""
from __future__ import annotations

import math
import re
from dataclasses import dataclass, field
from decimal import Decimal
from pathlib import Path
from typing import Any

__all__ = ["REFERENCES", "Comparison", "ComparisonRow", "Publication", "Reference", "compare",
           "doc_link", "slug"]

#: the repository's root (REPRODUCTION.md, docs/) when running from a source checkout
ROOT = Path(__file__).resolve().parents[2]


@dataclass(frozen=True)
class Publication:
    """A publication: its full citation and a short name for table headers."""

    citation: str
    short: str


THESIS = Publication(
    'M. Jafarian, "Variable stiffness for robust and energy efficient 2D bipedal locomotion", '
    "MSc report 022CE2010, Control Engineering, University of Twente, 2010", "thesis")
GARCIA = Publication(
    'M. Garcia, A. Chatterjee, A. Ruina, M. Coleman, "The simplest walking model: stability, '
    'complexity, and scaling", J. Biomech. Eng. 120(2):281–288, 1998', "Garcia et al. 1998")


@dataclass(frozen=True)
class Reference:
    """One published number.

    quantity : what is compared: a gait metric (``speed``), a fixed-point coordinate (``theta``),
        ``max_step_down`` or ``max_abs_multiplier``. printed : the value as published (text: its
        last digit sets the rounding ±½ unit). unit : the unit as published; ``factor`` converts
        our SI value into it (1000 for mm). where : table or section of the publication.
    uncertainty : stated uncertainty beyond the rounding, in ``unit`` (``"grid"``: the step-down
        grid of our run). explanation : one sentence on the difference. doc, heading : where the
        repository discusses it (a Markdown file and one of its headings).
    """

    quantity: str
    label: str
    printed: str
    unit: str
    where: str
    explanation: str
    doc: str
    heading: str
    factor: float = 1.0
    uncertainty: float | str = 0.0

    @property
    def value(self) -> float:
        return float(self.printed)

    @property
    def rounding(self) -> float:
        """Half a unit of the printed value's last digit."""
        return 0.5 * 10.0 ** int(Decimal(self.printed).as_tuple().exponent)


@dataclass(frozen=True)
class Comparison:
    """A model's published numbers and the parameter values they hold at."""

    publication: Publication
    conditions: dict[str, float]
    references: tuple[Reference, ...]


_T23 = "Table 2.3 — nominal gait at γ = 0.009 (`table_2_3`)"
_NOMINAL = {"slope": 0.009, "M": 3.0, "m_leg": 0.01, "m_foot": 0.1, "l": 0.7, "g": 9.81}
_FEET = ("the thesis's arc feet rolling on a compliant ground walk faster here: with point feet "
         "and a rigid impact the same masses give 0.267 m/s and 0.0770 J, within 3–4 % of the "
         "thesis, so the difference sits in the arc-foot contact model, which its text leaves open")

REFERENCES: dict[str, Comparison] = {
    "compass_walker": Comparison(THESIS, {**_NOMINAL, "R": 0.05, "K": 1.0e6, "lam": 3.16e7}, (
        Reference("speed", "speed", "0.274", "m/s", "Table 2.3", _FEET, "REPRODUCTION.md", _T23),
        Reference("energy_dissipated_per_step", "energy dissipated per step", "0.08", "J",
                  "Table 2.3", _FEET, "REPRODUCTION.md", _T23),
        Reference("max_step_down", "largest step-down survived", "2.4", "mm", "Table 2.3, §2.6",
                  "a step-down is found on a grid: ours is the largest grid height survived, so "
                  "the true value lies within one grid step above it",
                  "REPRODUCTION.md", _T23, factor=1e3, uncertainty="grid"),
    )),
    "rigid_compass_walker": Comparison(THESIS, dict(_NOMINAL), (
        Reference("speed", "speed", "0.274", "m/s", "Table 2.3",
                  "the thesis's walker has 5 cm arc feet on a compliant ground; this one the same "
                  "masses on point feet with a rigid impact, the limit its contact converges to",
                  "REPRODUCTION.md", _T23),
        Reference("energy_dissipated_per_step", "energy dissipated per step", "0.08", "J",
                  "Table 2.3",
                  "point feet with a rigid plastic impact instead of the thesis's arc feet on a "
                  "compliant ground", "REPRODUCTION.md", _T23),
    )),
    "simplest_walker": Comparison(GARCIA, {"slope": 0.009, "M": 1.0, "l": 1.0, "g": 1.0}, (
        Reference("theta", "θ just after heel strike", "0.20031090049483", "rad", "Table 1",
                  "Garcia's numbers are the limit β → 0 of the foot mass ratio; β = 1e-9 here "
                  "moves them by less than 1e-7", "docs/walkers.md", "The rigid-impact walkers",
                  uncertainty=1e-7),
        Reference("theta_dot", "θ̇ just after heel strike", "-0.19983247291764", "rad/s",
                  "Table 1", "as for θ: β = 1e-9 instead of the limit β → 0",
                  "docs/walkers.md", "The rigid-impact walkers", uncertainty=1e-7),
        Reference("max_abs_multiplier", "largest |Floquet multiplier|", "0.5883", "1",
                  "Table 1: |−0.19121 ± 0.55633i|",
                  "Garcia's multipliers come from finite differences accurate to about 1e-3 "
                  "(Bhounsule 2014); ours carry their own error estimate",
                  "docs/walkers.md", "The rigid-impact walkers", uncertainty=1e-3),
    )),
}


@dataclass
class ComparisonRow:
    """One row of the comparison: published (also as printed) and our value (in the published
    unit), the deviation (ours − published, relative), the tolerance (absolute, in ``unit``;
    None when none can be stated) and whether they agree within it."""

    quantity: str
    label: str
    unit: str
    published: float
    printed: str
    where: str
    ours: float | None
    deviation: float | None
    tolerance: float | None
    agrees: bool | None
    explanation: str
    doc: str
    heading: str
    source: str = field(default="")


def _ours(reference: Reference, gait: Any, step_down: Any) -> float | None:
    q = reference.quantity
    if q == "max_step_down":
        value = getattr(step_down, "max_step_down", None)
    elif q == "max_abs_multiplier":
        mults = list(getattr(gait, "floquet_multipliers", None) or [])
        value = max(abs(complex(m)) for m in mults) if mults else None
    elif q in (gait.fixed_point or {}):
        value = gait.fixed_point[q]
    else:
        value = getattr(gait.metrics, q, None)
    if value is None or not math.isfinite(float(value)):
        return None
    return float(value) * reference.factor


def _tolerance(reference: Reference, step_down: Any) -> float | None:
    extra = reference.uncertainty
    if extra == "grid":
        grid = getattr(step_down, "resolution", None)
        if grid is None or not math.isfinite(grid):
            return None
        extra = grid * reference.factor
    return reference.rounding + float(extra)


def differing_conditions(walker: Any) -> dict[str, tuple[float, float]]:
    """The parameters of ``walker`` whose values differ from its publication's conditions:
    ``{name: (ours, published)}`` (empty when the comparison applies or there is none)."""
    comparison = REFERENCES.get(walker.name)
    if comparison is None:
        return {}
    return {k: (walker.parameters.get(k, math.nan), v) for k, v in comparison.conditions.items()
            if not math.isclose(walker.parameters.get(k, math.nan), v, rel_tol=1e-12)}


def compare(walker: Any, gait: Any, step_down: Any = None) -> list[ComparisonRow]:
    """The comparison rows of ``walker`` (module docstring); [] when there is no publication for
    it or the run's parameters differ from the publication's (:func:`differing_conditions`)."""
    comparison = REFERENCES.get(walker.name)
    if comparison is None or differing_conditions(walker):
        return []
    rows = []
    for ref in comparison.references:
        ours = _ours(ref, gait, step_down)
        tol = _tolerance(ref, step_down)
        deviation = None if ours is None else (ours - ref.value) / abs(ref.value)
        agrees = None if ours is None or tol is None else abs(ours - ref.value) <= tol
        rows.append(ComparisonRow(ref.quantity, ref.label, ref.unit, ref.value, ref.printed,
                                  ref.where, ours,
                                  deviation, tol, agrees, ref.explanation, ref.doc, ref.heading,
                                  f"{comparison.publication.short}, {ref.where}"))
    return rows


def slug(heading: str) -> str:
    """GitHub's anchor of a Markdown heading: lower case, punctuation dropped (letters, digits,
    ``_``, ``-`` and spaces kept), spaces to hyphens."""
    text = re.sub(r"[^\w\- ]", "", heading.strip().lower())
    return text.replace(" ", "-")


def doc_link(doc: str, heading: str, out: str | Path) -> str | None:
    """A relative link from directory ``out`` to ``doc#heading`` in this source tree, or None
    when the file is not there (an installed package without the repository's documents)."""
    import os
    target = ROOT / doc
    if not target.is_file():
        return None
    rel = os.path.relpath(target, Path(out).resolve())
    return f"{Path(rel).as_posix()}#{slug(heading)}"
