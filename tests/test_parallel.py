"""Parallel solves (run.workers, run.scheduler = Dask) and multi-start (identify.starts): the same result.json
wherever the solves run, a worker killed mid-run, the client killed then --resume, bad input."""

import json
import os
import signal
import sqlite3
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pytest

from block2d_case import MODEL_TABLE, POINTS, TRUE, data_table
from frictionid.cli import main
from helpers import write_config

# finite differences (each Jacobian's columns solved at once) and two starts (side by side)
IDENTIFY = '[identify]\njacobian = "forward"\nstep = 1e-3\nstarts = 2\nseed = 3\n'


def _config(folder: Path, name: str, run: str = "", identify: str = IDENTIFY, zones="A = 0.1, B = 0.1, C = 0.1",
            data: str = "measured.csv") -> Path:
    return write_config(folder / name, identify + f'[run]\ndir = "runs/{Path(name).stem}"\nfields = false\n' + run,
                        model=MODEL_TABLE, friction=f"zones = {{ {zones} }}\n", data=data_table(data))


@pytest.fixture(scope="module")
def measured(tmp_path_factory):
    """Data made by `frictionid simulate` at known coefficients."""
    folder = tmp_path_factory.mktemp("parallel")
    (folder / "points.csv").write_text(POINTS)
    truth = _config(folder, "truth.toml", zones=", ".join(f"{k} = {v}" for k, v in TRUE.items()), data="points.csv")
    assert main(["simulate", str(truth), "--out", str(folder / "measured.csv")]) == 0
    return folder


@pytest.fixture(scope="module")
def reference(measured):
    """result.json of the identification in this process with 1 worker: what every other way of running must
    reproduce bit for bit."""
    assert main(["identify", str(_config(measured, "serial.toml"))]) == 0
    return _result(measured, "serial")


def _result(folder: Path, name: str) -> dict:
    return json.loads((folder / "runs" / name / "result.json").read_text())


def _same_fit(result: dict, reference: dict) -> None:
    """Bitwise the same coefficients, uncertainties, objective, history and starts."""
    for key in ("parameters", "objective", "history", "starts", "n_iterations"):
        assert result[key] == reference[key], key


def _evaluations(store: Path) -> list[bytes]:
    try:
        with sqlite3.connect(store) as db:
            return [x for (x,) in db.execute("SELECT x FROM evaluations")]
    except sqlite3.Error:
        return []


@pytest.fixture(scope="module")
def cluster():
    """A LocalCluster of 2 worker processes started by the test, as a user's cluster would be."""
    from distributed import Client, LocalCluster
    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as local:
        with Client(local) as client:
            yield local, client


@pytest.mark.slow
def test_the_reference_run_is_a_multi_start_finite_difference_fit(reference):
    assert reference["status"] == "converged" and len(reference["starts"]) == 2
    assert sum(s["best"] for s in reference["starts"]) == 1
    assert reference["starts"][1]["initial"] != reference["starts"][0]["initial"]      # a drawn start
    for zone, value in TRUE.items():
        assert reference["parameters"][zone]["value"] == pytest.approx(value, abs=1e-4)


@pytest.mark.slow
def test_every_start_is_in_the_text_and_html_report(measured, reference):
    from frictionid.report.tables import result_summary
    text = result_summary(reference)
    best = next(s for s in reference["starts"] if s["best"])
    assert "[[Starts]]" in text and f" *   {best['start']}  from " in text
    assert reference["objective"]["final"] == best["objective"]
    page = (measured / "runs/serial/report.html").read_text()
    section = page[page.index("<h2>Starts</h2>"):].split("</section>")[0]
    assert section.count("<tr><td>") == 2 and section.count("<td>yes</td>") == 1


@pytest.mark.slow
@pytest.mark.parametrize("run", ["workers = 2\n", 'workers = 2\nscheduler = "local"\n', "cluster"])
def test_the_same_result_with_1_worker_2_processes_and_a_2_worker_dask_cluster(measured, reference, cluster, run):
    if run == "cluster":
        run = f'scheduler = "{cluster[0].scheduler_address}"\n'
    name = f"run{abs(hash(run))}"
    assert main(["identify", str(_config(measured, f"{name}.toml", run))]) == 0
    _same_fit(_result(measured, name), reference)


class BusyWorkerKiller(threading.Thread):
    """Kills (SIGKILL) one worker process of a test-started cluster while it runs a task, once the run's store
    holds ``after`` evaluations."""

    def __init__(self, local, client, store: Path, after: int = 4):
        super().__init__()
        self.local, self.pids, self.store, self.after, self.killed = local, client.run(os.getpid), store, after, {}

    def run(self):
        deadline = time.monotonic() + 120
        while time.monotonic() < deadline:
            if len(_evaluations(self.store)) >= self.after:
                for address, state in list(self.local.scheduler.workers.items()):
                    if state.processing and address in self.pids:
                        os.kill(self.pids[address], signal.SIGKILL)
                        self.killed[address] = self.pids[address]
                        return
            time.sleep(0.005)


@pytest.mark.slow
def test_a_worker_killed_mid_run_the_run_completes_with_the_same_result(measured, reference, cluster):
    """SIGKILL to a worker process of the cluster while it solves: its solve is run again elsewhere, the nanny
    starts a new worker, the run ends as the reference."""
    local, client = cluster
    config = _config(measured, "killworker.toml", f'scheduler = "{local.scheduler_address}"\n')
    killer = BusyWorkerKiller(local, client, measured / "runs/killworker/store.sqlite")
    killer.start()
    try:
        assert main(["identify", str(config)]) == 0
    finally:
        killer.join()
    assert killer.killed, "the test must kill a worker while it solves"
    _same_fit(_result(measured, "killworker"), reference)
    client.wait_for_workers(2, timeout=60)                # the nanny replaced it
    assert set(client.run(os.getpid).values()).isdisjoint(killer.killed.values())


@pytest.mark.slow
def test_a_solve_lost_more_often_than_allowed_stops_the_run_with_exit_1_and_resume_completes(measured, reference,
                                                                                             cluster, capsys):
    """A cluster that allows no failure (distributed.scheduler.allowed-failures = 0, what run.retries = 0 sets
    for a local cluster): the killed worker's solve is not retried, the run stops with exit 1 naming
    --resume, and --resume on a sound cluster ends as the reference."""
    import dask
    from distributed import Client, LocalCluster
    config = _config(measured, "noretry.toml")
    with dask.config.set({"distributed.scheduler.allowed-failures": 0}), \
            LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as strict, \
            Client(strict) as client:
        config.write_text(config.read_text() + f'scheduler = "{strict.scheduler_address}"\nretries = 0\n')
        killer = BusyWorkerKiller(strict, client, measured / "runs/noretry/store.sqlite")
        killer.start()
        try:
            assert main(["identify", str(config)]) == 1
        finally:
            killer.join()
    assert killer.killed
    err = capsys.readouterr().err
    assert "a forward solve did not come back (KilledWorker" in err and "--resume" in err
    assert json.loads((measured / "runs/noretry/result.json").read_text())["status"] == "failed"
    config.write_text(config.read_text().replace(strict.scheduler_address, cluster[0].scheduler_address))
    assert main(["identify", str(config), "--resume"]) == 0
    _same_fit(_result(measured, "noretry"), reference)


@pytest.mark.slow
def test_the_client_killed_then_resume_completes_with_the_same_result_without_recomputing(measured, reference):
    import psutil
    config = _config(measured, "killclient.toml", 'workers = 2\nscheduler = "local"\n')
    store = measured / "runs/killclient/store.sqlite"
    child = subprocess.Popen([sys.executable, "-m", "frictionid.cli", "identify", str(config)],
                             stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    workers = []
    try:
        deadline = time.monotonic() + 180
        while len(_evaluations(store)) < 12 and time.monotonic() < deadline and child.poll() is None:
            time.sleep(0.01)
        workers = psutil.Process(child.pid).children(recursive=True)
        os.kill(child.pid, signal.SIGKILL)
        child.wait()
        _, alive = psutil.wait_procs(workers, timeout=30)
        assert not alive, "the cluster's processes must end with their client"
    finally:
        for process in workers:                       # only if the assertion above failed
            if process.is_running():
                process.kill()
    before = _evaluations(store)
    assert 12 <= len(before) < reference["n_forward_solves"], "the kill must land in the middle of the run"
    assert main(["identify", str(config), "--resume"]) == 0
    resumed = _result(measured, "killclient")
    _same_fit(resumed, reference)
    after = _evaluations(store)
    assert after[:len(before)] == before and len(set(after)) == len(after), "a stored solve was run again"
    assert resumed["n_replayed"] >= len(before)


def test_a_malformed_scheduler_exits_2_naming_the_key(measured, capsys):
    config = _config(measured, "badscheduler.toml", 'scheduler = "127.0.0.1:8786"\n')
    assert main(["identify", str(config)]) == 2
    err = capsys.readouterr().err
    assert "run.scheduler = '127.0.0.1:8786'" in err and "tcp://host:port" in err and "Traceback" not in err
    assert not (measured / "runs/badscheduler").exists()


def test_an_unreachable_scheduler_exits_2_naming_the_key_and_leaves_no_store(measured, capsys, monkeypatch):
    import socket

    import frictionid.run.cluster as cluster_module
    monkeypatch.setattr(cluster_module, "CONNECT_TIMEOUT", 1.0)
    with socket.socket() as free:                     # a port nobody listens on
        free.bind(("127.0.0.1", 0))
        port = free.getsockname()[1]
    config = _config(measured, "unreachable.toml", f'scheduler = "tcp://127.0.0.1:{port}"\n')
    assert main(["identify", str(config)]) == 2
    err = capsys.readouterr().err
    assert f"run.scheduler = 'tcp://127.0.0.1:{port}': no Dask scheduler answered within 1 s" in err
    assert not (measured / "runs/unreachable/store.sqlite").exists()


@pytest.mark.parametrize("change, message", [
    ("starts = 0", "identify.starts must be at least 1"),
    ("starts = [[0.1, 0.2]]", "identify.starts: [0.1, 0.2] must be a list of 3 numbers"),
    ("starts = [{ A = 0.1, Q = 0.2 }]", "must map free zones ['A', 'B', 'C'] to numbers"),
    ("starts = [[0.1, 0.2, 1.5]]", "identify.starts: start 1 [0.1, 0.2, 1.5] is outside the bounds"),
    ('starts = "2"', "identify.starts must be a number of starts or a list of start points"),
])
def test_bad_starts_exit_2_naming_the_key(measured, capsys, change, message):
    config = _config(measured, "badstarts.toml", identify=IDENTIFY.replace("starts = 2", change))
    assert main(["identify", str(config)]) == 2
    assert message in capsys.readouterr().err


def test_start_points_are_the_configured_start_then_seeded_draws_within_the_bounds():
    from frictionid.inverse.multistart import start_points
    x0, lower, upper = np.array([0.1, 0.1]), np.array([0.0, 0.05]), np.array([0.6, 0.2])
    points = start_points(5, x0, lower, upper, seed=3)
    np.testing.assert_array_equal(points[0], x0)
    assert np.all((points >= lower) & (points <= upper)) and len({tuple(p) for p in points}) == 5
    np.testing.assert_array_equal(points, start_points(5, x0, lower, upper, seed=3))
    assert not np.array_equal(points, start_points(5, x0, lower, upper, seed=4))
    given = start_points([[0.2, 0.1], {"B": 0.15}], x0, lower, upper, names=("A", "B"))
    np.testing.assert_array_equal(given, [[0.2, 0.1], [0.1, 0.15]])


@pytest.mark.ccx
@pytest.mark.slow
def test_a_calculix_finite_difference_jacobian_is_the_same_on_a_dask_cluster(tmp_path):
    """The columns of a ccx forward-difference Jacobian as Dask tasks (scheduler = "local", 2 workers): the same
    Jacobian as in this process, every perturbed run stored as it arrives."""
    from frictionid.backends.calculix.backend import CalculixBackend, CalculixSettings
    from frictionid.builders.block import block_model_2d
    from frictionid.inverse.evaluator import Evaluator
    from frictionid.inverse.observations import Observations
    from frictionid.inverse.parameters import Parameters
    from frictionid.run.executor import make_executor
    from frictionid.run.store import RunStore
    model = block_model_2d(mesh_size=2.0, pull=0.05)
    points = np.array([[-5.0, 0.5], [5.0, 0.5], [-7.0, 0.0], [7.0, 0.0]])
    regions = ["block", "block", "base", "base"]
    backend = CalculixBackend(model, points, ("ux", "uy"), regions, CalculixSettings(work_dir=str(tmp_path)))
    obs = Observations(points, tuple(regions), ("ux", "uy"), np.arange(8), np.ones(8, int), np.zeros(8),
                       np.full(8, 1e-3), tuple(map(str, range(8))), True)
    params = Parameters.from_config(model.zone_names, {"A": 0.3, "B": 0.2}, bounds=(0.0, 1.0))
    jacobians = []
    for name, scheduler in (("serial", None), ("dask", "local")):
        store = RunStore.open(tmp_path / name, "", "f", resume=False)
        evaluator = Evaluator(backend, obs, params, store, jacobian="forward", step=1e-2,
                              executor=make_executor(backend, 2 if scheduler else 1, scheduler))
        try:
            jacobians.append(evaluator.jacobian(params.x0))
        finally:
            evaluator.close()
        assert store.n_evaluations("forward") == 3 and evaluator.n_failed == 0
    np.testing.assert_array_equal(jacobians[0], jacobians[1])
    assert np.all(np.abs(jacobians[0]) > 0)


@pytest.mark.slow
def test_the_python_interface_takes_scheduler_and_starts(measured, reference):
    from frictionid import identify
    result = identify({"builder": "block2d", "mesh_size": 1.0, "height": 4.0, "n_zones": 3},
                      measured / "measured.csv", {"A": 0.1, "B": 0.1, "C": 0.1}, observables=["ux", "uy"],
                      stages=[2], noise={"u": 0.0005}, regions={"P1": "block", "P2": "block", "P3": "block",
                                                                  "P4": "block", "P5": "base", "P6": "base"},
                      workers=2, scheduler="local", jacobian="forward", step=1e-3, starts=2, seed=3)
    data = result.to_dict()
    assert data["starts"] == reference["starts"]
    assert {k: p["value"] for k, p in data["parameters"].items()} == \
        {k: p["value"] for k, p in reference["parameters"].items()}
