"""The report's comparison with the publications and its labels and units, without running a
walker (walker_library.report.comparison, walker_library.report.labels, walker_library.report.page).

Published numbers: M. Jafarian (2010), MSc report 022CE2010, University of Twente, Table 2.3:
speed 0.274 m/s, energy dissipated per step 0.08 J, max step-down 2.4 mm; Garcia et al. (1998),
J. Biomech. Eng. 120:281, Table 1 (γ = 0.009): θ* = 0.20031090049483 rad.
"""
from __future__ import annotations

import math
import re
from types import SimpleNamespace

import pytest

from walker_library.core.files import read_walker
from walker_library.core.protocol import ParameterSpec
from walker_library.report.comparison import REFERENCES, ROOT, compare, doc_link, slug
from walker_library.report.labels import (
    describe,
    foot_radius,
    is_nondimensional,
    pretty_unit,
    shown_unit,
)
from walker_library.report.page import multiplier_cells, number, text


def _walker(name: str, **changes: float) -> SimpleNamespace:
    """What the comparison and the labels read of a walker, from its file (no compilation)."""
    spec, _ = read_walker(name)
    modes = set(spec.mode_names)
    specs = {k: ParameterSpec(k, p.value, p.unit, p.doc) for k, p in spec.model.parameters.items()
             if k not in modes}
    joints = spec.model.component("walker").value("joints")
    return SimpleNamespace(name=name, spec=spec, multibody="walker", specs=specs,
                           joint_types={j: str(d.get("type", "")) for j, d in joints.items()},
                           parameters={**{k: s.value for k, s in specs.items()}, **changes})


def _gait(metrics: dict, fixed_point: dict | None = None, multipliers=()) -> SimpleNamespace:
    return SimpleNamespace(metrics=SimpleNamespace(**metrics), fixed_point=fixed_point or {},
                           floquet_multipliers=list(multipliers))


def test_compass_walker_rows_against_table_2_3():
    walker = _walker("compass_walker")
    gait = _gait({"speed": 0.304976, "energy_dissipated_per_step": 0.0873606})
    step_down = SimpleNamespace(max_step_down=0.00252, resolution=0.00014)
    rows = {r.quantity: r for r in compare(walker, gait, step_down)}
    speed = rows["speed"]
    assert speed.published == 0.274 and speed.unit == "m/s"
    assert speed.deviation == pytest.approx((0.304976 - 0.274) / 0.274, rel=1e-12)
    assert speed.tolerance == pytest.approx(0.0005)          # rounding of "0.274"
    assert speed.agrees is False and "arc-foot" in speed.explanation
    energy = rows["energy_dissipated_per_step"]
    assert energy.tolerance == pytest.approx(0.005) and energy.agrees is False
    sd = rows["max_step_down"]                               # in mm, the grid added
    assert sd.ours == pytest.approx(2.52) and sd.tolerance == pytest.approx(0.05 + 0.14)
    assert sd.agrees is True
    assert "University of Twente" in REFERENCES["compass_walker"].publication.citation
    assert "022CE2010" in REFERENCES["compass_walker"].publication.citation


def test_no_comparison_at_other_parameters():
    walker = _walker("compass_walker", slope=0.012)
    gait = _gait({"speed": 0.3, "energy_dissipated_per_step": 0.1})
    assert compare(walker, gait, None) == []


def test_the_tolerance_decides():
    walker = _walker("simplest_walker")
    close = _gait({}, {"theta": 0.20031090049483 + 5e-8, "theta_dot": -0.19983247291764},
                  [complex(-0.1901, 0.5576), complex(-0.1901, -0.5576), 1e-6])
    far = _gait({}, {"theta": 0.2005, "theta_dot": -0.19983247291764})
    rows = {r.quantity: r for r in compare(walker, close)}
    assert rows["theta"].agrees and rows["theta_dot"].agrees
    assert rows["max_abs_multiplier"].ours == pytest.approx(abs(complex(-0.1901, 0.5576)))
    assert rows["max_abs_multiplier"].agrees                 # within 1e-3 of 0.5883
    rows = {r.quantity: r for r in compare(walker, far)}
    assert rows["theta"].agrees is False
    assert rows["max_abs_multiplier"].ours is None and rows["max_abs_multiplier"].agrees is None


def test_links_point_at_existing_headings(tmp_path):
    for comparison in REFERENCES.values():
        for ref in comparison.references:
            doc = (ROOT / ref.doc).read_text()
            headings = [slug(h) for h in re.findall(r"^#+ (.+)$", doc, re.MULTILINE)]
            assert slug(ref.heading) in headings, (ref.doc, ref.heading)
            link = doc_link(ref.doc, ref.heading, tmp_path / "report")
            assert link is not None and link.endswith("#" + slug(ref.heading))
    assert slug("Table 2.3 — nominal gait at γ = 0.009 (`table_2_3`)") == \
        "table-23--nominal-gait-at-γ--0009-table_2_3"             # GitHub's anchor


def test_labels_and_units_from_the_model_file():
    walker = _walker("compass_walker")
    assert describe(walker, "walker.v.hip_joint.x").unit == "m/s"
    assert "along the slope" in describe(walker, "walker.v.hip_joint.x").label
    assert describe(walker, "walker.q.leg1").unit == "rad"
    assert describe(walker, "theta").label == "θ stance-leg angle"
    assert describe(walker, "speed").unit == "m/s"
    compliant = _walker("compliant_leg_walker")
    assert describe(compliant, "ankle_lead").unit == "m"        # a prismatic joint: the leg spring
    ankle = _walker("ankle_stiffness_walker")
    assert describe(ankle, "ankle_lead").unit == "rad"          # a revolute ankle
    assert not is_nondimensional(walker) and is_nondimensional(_walker("simplest_walker"))
    assert shown_unit("m/s", True) == "nondim." and shown_unit("rad", True) == "rad"
    assert pretty_unit("N*s/m^2") == "N·s/m²" and pretty_unit("m/s^-1") == "m/s⁻¹"


def test_foot_radius_reads_the_contact():
    walker = _walker("compass_walker")
    values = {k: float(v.value) for k, v in walker.spec.model.parameters.items()}
    assert [foot_radius(walker, f, values) for f in walker.spec.feet] == [0.05, 0.05]
    rigid = _walker("simplest_walker")
    assert [foot_radius(rigid, f, {}) for f in rigid.spec.feet] == [0.0, 0.0]


def test_multipliers_to_the_digits_their_error_supports():
    rows, small = multiplier_cells([complex(-0.09304, 0.26204), complex(-0.09304, -0.26204),
                                    5.6e-5, 1.1e-6, 8e-10], 4.04e-4)
    assert rows[0] == ["-0.0930 ± 0.2620i", "0.2781"]      # |λ| = 0.27807
    assert small == 3 and rows[-1] == ["3 multipliers", "< 5×10⁻⁴"]
    rows, small = multiplier_cells([0.5, 0.25], math.nan)       # no estimate: 3 digits
    assert rows == [["0.5", "0.5"], ["0.25", "0.25"]] and small == 0


def test_no_python_literals_in_prose():
    assert text(None) == text(math.nan) == number(None) == "—"
    assert text(True) == "yes" and text(False) == "no"
    assert number(0.1234567891) == "0.123457"
