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
    assert len(STUDIES) == 12
