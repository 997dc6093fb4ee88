"""``walker reproduce`` (walker_library.report.studies): studies run on coarse grids (``--quick``) write
their figures, results and summary rows beside the thesis's numbers; an unknown study is refused
with the list of studies. The full studies and their numbers are in REPRODUCTION.md."""
from __future__ import annotations

import json

import pytest
from PIL import Image

from porthamiltonian.errors import ModelError
from walker_library.cli import main
from walker_library.report.studies import STUDIES, run_studies


def test_quick_studies_write_figures_and_thesis_rows(tmp_path, capsys, without_views):
    out = tmp_path / "repro"
    assert main(["reproduce", "damping_calibration", "slope_multipliers", "--quick", "--serial",
                 "--quiet", "--out", str(out)]) == 0
    printed = capsys.readouterr().out
    assert "period-1/period-2 boundary" in printed and "thesis" in printed
    summary = json.loads((out / "reproduction.json").read_text())
    assert set(summary) == {"damping_calibration", "slope_multipliers"}
    cal = {r["quantity"]: r for r in summary["damping_calibration"]["rows"]}
    # the thesis's rule on a coarse λ grid (1e5 ... 1e10, one per decade): the plateau starts
    # at 1e8 there (3.16e7 on the default grid of four per decade)
    assert cal["calibrated λ"]["ours"] == pytest.approx(1e8)
    # the quick continuation: the period-1 branch from γ = 0.009 to 0.014, stable throughout
    table = summary["slope_multipliers"]["table"]
    assert table[0]["slope"] == 0.009 and table[-1]["slope"] == pytest.approx(0.014)
    assert all(r["period_steps"] == 1 and r["stable"] for r in table)
    assert table[0]["max_multiplier"] == pytest.approx(0.264, abs=5e-3)   # 0.278 with point legs
    for png in ("damping_calibration/fig_2_12_dissipation_over_lambda.png",
                "slope_multipliers/table_2_2_bifurcation_diagram.png"):
        with Image.open(out / png) as im:
            im.verify()
    # a second run of one study keeps the other's summary
    run_studies(["damping_calibration"], out, quick=True, serial=True, progress="none",
                log=lambda msg: None)
    assert set(json.loads((out / "reproduction.json").read_text())) == set(summary)


def test_unknown_study_is_refused_with_the_list():
    with pytest.raises(ModelError, match="unknown study 'table_9_9'; studies: table_2_3"):
        run_studies(["table_9_9"], "unused")
    assert len(STUDIES) == 13


def test_the_kneed_walker_study_sets_ours_beside_hsu_chens(tmp_path, without_views):
    """``walker reproduce kneed_walker --quick``: the rows compare our exact fixed point, step
    period and multipliers with V. F. Hsu Chen's M.Eng. thesis (MIT 2007, sec. 3.3; its fixed
    point from a fixed-step search, 4 digits: within 1 % in q1, q1_dot; its swing rate a
    difference of two rates near 1.1 rad/s: within 0.02 rad/s; its period digitised from a
    figure, ± 2 %; its eigenvalues a least-squares fit: both stable), ours pinned to 1e-6 as
    tests/walkers/test_kneed_walker.py pins the gait; the figures are written."""
    summary = run_studies(["kneed_walker"], tmp_path, quick=True, serial=True, progress="none",
                          log=lambda msg: None)["kneed_walker"]
    rows = {r["quantity"]: r for r in summary["rows"]}
    assert len(rows) == 6                  # --quick: no continuation over the slope
    q1, q2 = rows["q1, stance leg from the vertical"], rows["q2 = q3, swing leg from the vertical"]
    q1_dot, q2_dot = rows["q̇1"], rows["q̇2 = q̇3"]
    period, eig = rows["step period"], rows["max |return-map eigenvalue|"]
    assert q1["thesis"] == 0.1877 and abs(q1["deviation"]) < 1e-2
    assert q1_dot["thesis"] == -1.1014 and abs(q1_dot["deviation"]) < 1e-2
    assert abs(q2["ours"] - q2["thesis"]) < 1e-2 * abs(q2["thesis"])
    assert abs(q2_dot["ours"] - q2_dot["thesis"]) < 2e-2
    assert abs(period["deviation"]) < 2e-2
    assert eig["ours"] < 1 and eig["thesis"] < 1
    ours = (q1["ours"], q2["ours"], q1_dot["ours"], q2_dot["ours"], period["ours"], eig["ours"])
    assert ours == pytest.approx((0.188185460, -0.288985460, -1.109587331, -0.057148106,
                                  0.564328166, 0.655168477), abs=1e-6)
    for png in ("angles.png", "multipliers.png"):
        with Image.open(tmp_path / "kneed_walker" / png) as im:
            im.verify()
