"""Shared by the sweep tests: the reference (uninterrupted, serial, in-process) run of the real
walker sweep, simplest_walker gait over 4 slopes with the C back end."""
from __future__ import annotations

import pytest
from sweep_cases import GAIT_CASES, GAIT_FIXED

from porthamiltonian.batch import Sweep, load_results
from walker_library.analyses.cases import gait_case


@pytest.fixture(scope="session")
def gait_reference(tmp_path_factory, isolated_cache) -> dict[int, tuple]:
    """{case_id: (case, status, result)} of an uninterrupted serial run."""
    path = tmp_path_factory.mktemp("gait_reference") / "reference.jsonl"
    Sweep(gait_case, GAIT_CASES, path, fixed=GAIT_FIXED).run(serial=True, progress="none")
    rows = load_results(path)
    assert sorted(r["case_id"] for r in rows) == [0, 1, 2, 3]
    return {r["case_id"]: (r["case"], r["status"], r["result"]) for r in rows}
