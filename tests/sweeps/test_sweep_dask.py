"""The same sweeps through a dask.distributed cluster (docs/sweeps.md): a local cluster of two
single-threaded workers (processes=False: workers in this process, started in well under a
second here; processes=True costs ~5 s of start-up on the 2-core machine and computes the same
numbers), used through ``client.get_executor()`` and through ``walker sweep --scheduler``."""
from __future__ import annotations

import json

import pytest
import sweep_cases
from sweep_cases import GAIT_CASES, GAIT_FIXED

from porthamiltonian.batch import Sweep, grid, load_results
from walker_library.analyses.cases import gait_case
from walker_library.cli import main


@pytest.fixture(scope="module")
def client():
    """A local dask.distributed cluster (imported here, not at collection, where every
    pytest-xdist worker imports every test module: 0.3 s)."""
    from distributed import Client, LocalCluster

    with LocalCluster(n_workers=2, threads_per_worker=1, processes=False,
                      dashboard_address=None) as cluster, Client(cluster) as c:
        yield c


def _results(rows):
    return {r["case_id"]: (r["case"], r["status"], r["result"]) for r in rows}


def test_gait_sweep_through_dask_resumes_a_serial_file_to_the_same_table(tmp_path, client,
                                                                           gait_reference):
    """Cases 0, 1 and 3 run serially (the reference's rows), the sweep is then finished on the
    dask cluster (case 2; the chaotic case 3, ~5 s of CPU, is the serial reference's: the
    cluster's part is how a case reaches a worker and its row the file, the same for every
    case): the table equals the serial reference, number for number."""
    path = tmp_path / "gait.jsonl"
    sweep = Sweep(gait_case, GAIT_CASES, path, fixed=GAIT_FIXED)
    rows = [json.dumps({"case_id": i, "case": case, "status": status, "result": result,
                        "seconds": 0.0, "worker": "serial", "finished": "-"})
            for i, (case, status, result) in sorted(gait_reference.items()) if i != 2]
    path.write_text(sweep._header_line().decode() + "\n".join(rows) + "\n")
    report = Sweep(gait_case, GAIT_CASES, path, fixed=GAIT_FIXED).run(client.get_executor(),
                                                                      progress="none")
    assert (report.n_run, report.n_previously_done, report.complete) == (1, 3, True)
    rows = load_results(path)
    assert sorted(r["case_id"] for r in rows) == [0, 1, 2, 3]
    assert _results(rows) == gait_reference
    # γ = 0.019 lies in the simplest walker's chaotic range: only unstable orbits there (the
    # gait search continues the file's gait through the period doublings and finds no stable one)
    assert [gait_reference[i][1] for i in range(4)] == ["periodic"] * 4
    assert [gait_reference[i][2]["stable"] for i in range(4)] == [True, True, True, False]


def test_failing_cases_through_dask_are_rows(tmp_path, client):
    sweep = Sweep(sweep_cases.mixed_case, grid(x=[-1, 0, 4]), tmp_path / "s.jsonl")
    report = sweep.run(client.get_executor(), progress="none")
    assert report.status_counts == {"error": 1, "fell": 1, "ok": 1}
    assert [r["status"] for r in sweep.table()] == ["error", "fell", "ok"]
    assert sweep.table()[0]["message"] == "ValueError: negative x = -1"


def test_command_line_scheduler_address(tmp_path, client, capsys, gait_reference):
    """The reference's first three slopes through ``walker sweep --scheduler`` (the fourth, γ =
    0.019, costs ~5 s of CPU: its gait search continues through the period doublings; it runs
    serially, in the reference)."""
    out = tmp_path / "gait.jsonl"
    code = main(["sweep", "simplest_walker", "--grid", "slope=0.004:0.014:3", "--out", str(out),
                 "--backend", "c", "--scheduler", client.scheduler.address, "--json"])
    assert code == 0
    doc = json.loads(capsys.readouterr().out)
    assert doc["report"]["n_run"] == 3 and doc["report"]["complete"]
    assert _results(load_results(out)) == {i: gait_reference[i] for i in range(3)}
    assert [r["status"] for r in doc["table"]] == ["periodic"] * 3
    assert [r["stable"] for r in doc["table"]] == [True, True, True]


@pytest.mark.parametrize("address, words", [
    ("bogus", "missing port number"),
    ("foo://127.0.0.1:1", "unknown address scheme 'foo'"),
    ("tcp://localhost:port", "'port'"),
])
def test_a_malformed_scheduler_address_exits_2_naming_it(tmp_path, capsys, address, words):
    """An address dask cannot parse is the user's (dask raises ValueError for these; it was
    reported as a bug in porthamiltonian, status 3, with dask's traceback): status 2 before any
    case runs, the address, dask's reason and the form to give."""
    path = tmp_path / "sweep.jsonl"
    status = main(["sweep", "rimless_wheel", "--grid", "slope=0.01,0.02", "--out", str(path),
                   "--scheduler", address, "--progress", "none"])
    err = capsys.readouterr().err
    assert status == 2 and "Traceback" not in err, err
    assert err.startswith(f"error: --scheduler {address!r} is not a dask scheduler address ("), err
    assert words in err and "give tcp://host:port, or 'local' for a local cluster" in err, err
    assert not path.exists() or "case_id" not in path.read_text()
