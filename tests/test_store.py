"""Run store: round trips, resume rules, fingerprint checks, concurrent reading and survival of kill -9."""

import signal
import sqlite3
import subprocess
import sys
import textwrap

import numpy as np
import pytest

from frictionid.errors import InputError
from frictionid.run import RunStore

CONFIG = '[model]\nbuilder = "block"\n[friction]\nzones = { A = 0.1, B = 0.1 }\n'


def open_store(run_dir, resume=False, config=CONFIG, fingerprint="f1"):
    return RunStore.open(run_dir, config, fingerprint, resume=resume)


def test_outputs_round_trip_exactly_with_shape_and_dtype(tmp_path):
    x = np.array([0.1, 0.30000000000000004])
    outputs = {"f": np.arange(6.0).reshape(2, 3) / 7, "jac": np.ones((2, 3, 2), dtype=np.float32),
               "converged": np.array(True), "n_increments": np.array([3, 4], dtype=np.int64)}
    with open_store(tmp_path / "run") as store:
        store.record(x, "forward", outputs, wall_time=1.5)
        found = store.lookup(x.copy(), "forward")
    assert found.keys() == outputs.keys()
    for name, value in outputs.items():
        assert found[name].dtype == value.dtype and found[name].shape == value.shape
        np.testing.assert_array_equal(found[name], value)


def test_lookup_needs_bitwise_equal_x_and_a_covering_kind(tmp_path):
    x = np.array([0.1, 0.2])
    with open_store(tmp_path) as store:
        store.record(x, "forward+sensitivities", {"f": np.array([1.0]), "df": np.array([[2.0, 3.0]])})
        store.record(np.array([0.5, 0.5]), "forward", {"f": np.array([7.0])})
        assert store.lookup(x, "forward")["f"][0] == 1.0
        assert "df" in store.lookup(x, "forward+sensitivities")
        assert store.lookup(np.nextafter(x, 1.0), "forward") is None  # one ulp away is another point
        assert store.lookup([0.5, 0.5], "forward+sensitivities") is None  # forward cannot serve sensitivities
        assert store.lookup([0.5, 0.5], "forward")["f"][0] == 7.0


def test_failed_evaluations_are_counted_but_not_served(tmp_path):
    with open_store(tmp_path) as store:
        store.record([0.2], "forward", {}, status="failed", wall_time=3.0)
        assert store.lookup([0.2], "forward") is None
        store.record([0.2], "forward", {"f": np.array([1.0])})
        store.record([0.3], "forward+sensitivities", {"f": np.array([2.0])})
        assert store.lookup([0.2], "forward")["f"][0] == 1.0
        assert (store.n_evaluations(), store.n_evaluations("forward")) == (3, 2)
        rows = list(store.evaluations())
    assert [(r.index, r.x.tolist(), r.kind, r.status, r.wall_time) for r in rows] == [
        (1, [0.2], "forward", "failed", 3.0), (2, [0.2], "forward", "ok", 0.0),
        (3, [0.3], "forward+sensitivities", "ok", 0.0)]
    assert rows[0].created <= rows[2].created
    assert rows[2]["kind"] == rows[2][2] == "forward+sensitivities"  # fields by name or position


def test_iterations_status_and_result_survive_reopening(tmp_path):
    with open_store(tmp_path) as store:
        assert store.status() == ("created", "") and store.result() is None and not store.resumed
        store.record_iteration(1, [0.2, 0.3], 0.5, {"step": np.float64(0.25)})
        store.record_iteration(0, [0.1, 0.1], 2.0)
        store.record_iteration(1, [0.2, 0.3], 0.25, {"step": 0.5})  # a resumed replay replaces iteration 1
        store.set_status("failed", "increment 3 did not converge")
        store.put_result({"status": "failed", "parameters": {"A": {"value": np.float64(0.2)}}, "ci": np.zeros(2)})
    with open_store(tmp_path, resume=True) as store:
        assert store.resumed
        assert [(r.iteration, r.x.tolist(), r.objective, r.extra) for r in store.iterations()] == [
            (0, [0.1, 0.1], 2.0, {}), (1, [0.2, 0.3], 0.25, {"step": 0.5})]
        assert [row["iteration"] for row in store.iterations()] == [0, 1]
        assert store.status() == ("failed", "increment 3 did not converge")
        assert store.result() == {"status": "failed", "parameters": {"A": {"value": 0.2}}, "ci": [0.0, 0.0]}


def test_a_write_interrupted_between_its_begin_and_commit_does_not_block_the_next_write(tmp_path):
    """Ctrl-C can land right after a write's BEGIN (CI saw "cannot start a transaction within a transaction" when
    the interrupted run then wrote its status): the half-done write is rolled back, the next one commits."""
    class Interrupting:
        def __array__(self, *args, **kwargs):
            raise KeyboardInterrupt

    with open_store(tmp_path) as store:
        store.record([0.1, 0.1], "forward", {"u": np.ones(2)})
        with pytest.raises(KeyboardInterrupt):          # inside the transaction's body
            store.record([0.2, 0.2], "forward", {"u": Interrupting()})
        store._conn.execute("BEGIN IMMEDIATE")          # as left by an interrupt between BEGIN and the body
        store._conn.execute("INSERT INTO iterations VALUES (7, x'00', 1.0, '{}', 'now')")
        store.set_status("interrupted", "stopped by the user; continue with --resume")
    with open_store(tmp_path, resume=True) as store:
        assert store.status() == ("interrupted", "stopped by the user; continue with --resume")
        assert store.n_evaluations() == 1 and store.iterations() == []


def test_resume_serves_the_same_lookups(tmp_path):
    rng = np.random.default_rng(1)
    points = rng.uniform(0, 1, (5, 4))
    with open_store(tmp_path) as store:
        for x in points:
            store.record(x, "forward", {"f": np.sin(x)})
    with open_store(tmp_path, resume=True) as store:
        for x in points:
            np.testing.assert_array_equal(store.lookup(x, "forward")["f"], np.sin(x))
        assert store.n_evaluations() == 5


def test_existing_store_without_resume_is_refused(tmp_path):
    open_store(tmp_path).close()
    with pytest.raises(InputError, match="already has a store; use --resume or another run.dir"):
        open_store(tmp_path)


def test_resume_with_other_inputs_names_the_changed_config_line(tmp_path):
    open_store(tmp_path).close()
    changed = CONFIG.replace("B = 0.1", "B = 0.2")
    with pytest.raises(InputError) as error:
        open_store(tmp_path, resume=True, config=changed, fingerprint="f2")
    message = str(error.value)
    assert str(tmp_path / "store.sqlite") in message
    assert "-zones = { A = 0.1, B = 0.1 }" in message and "+zones = { A = 0.1, B = 0.2 }" in message
    assert "builder" not in message  # only the differing line is shown
    with pytest.raises(InputError, match="config text is the same, so a file it names"):
        open_store(tmp_path, resume=True, fingerprint="f2")


@pytest.mark.parametrize("content", [b"not a database, just text\n" * 200, b"SQLite format 3\x00" + b"\xff" * 5000])
def test_a_file_that_is_not_a_store_is_an_input_error_naming_it(tmp_path, content):
    (tmp_path / "store.sqlite").write_bytes(content)
    with pytest.raises(InputError, match="store.sqlite: not a"):
        open_store(tmp_path, resume=True)


def test_a_store_with_damaged_pages_is_an_input_error_naming_it(tmp_path):
    with open_store(tmp_path) as store:
        for i in range(200):  # small outputs: every page is a b-tree page, whose damage quick_check sees
            store.record([float(i)], "forward", {"f": np.full(8, float(i))})
    path = tmp_path / "store.sqlite"  # closing the last connection checkpointed the WAL into this file
    page_size = 4096  # SQLite's default
    with open(path, "r+b") as file:  # one page in the evaluations, which opening the store does not read
        file.seek(path.stat().st_size // 4 // page_size * page_size)
        file.write(b"\x07" * page_size)
    with pytest.raises(InputError, match="store.sqlite: not a readable frictionid run store"):
        open_store(tmp_path, resume=True)


def test_an_empty_file_left_by_a_kill_during_creation_counts_as_no_store(tmp_path):
    (tmp_path / "store.sqlite").write_bytes(b"")
    with open_store(tmp_path, resume=True) as store:
        assert not store.resumed and store.status() == ("created", "")


def test_another_sqlite_database_is_not_taken_for_a_store(tmp_path):
    with sqlite3.connect(tmp_path / "store.sqlite") as conn:
        conn.execute("CREATE TABLE t (a)")
    conn.close()
    with pytest.raises(InputError, match="not a frictionid run store"):
        open_store(tmp_path, resume=True)


def test_writes_are_not_blocked_by_a_reader_in_a_transaction(tmp_path):
    writer = open_store(tmp_path)
    writer.record([0.1], "forward", {"f": np.array([1.0])})
    reader = sqlite3.connect(tmp_path / "store.sqlite", isolation_level=None, timeout=0.5)
    reader.execute("BEGIN")
    assert reader.execute("SELECT COUNT(*) FROM evaluations").fetchone()[0] == 1
    writer._conn.execute("PRAGMA busy_timeout = 500")  # fail fast if the reader blocks the commit
    writer.record([0.2], "forward", {"f": np.array([2.0])})
    assert reader.execute("SELECT COUNT(*) FROM evaluations").fetchone()[0] == 1  # snapshot isolation
    reader.execute("COMMIT")
    with open_store(tmp_path, resume=True) as second:
        assert second.n_evaluations() == 2 and second.lookup([0.2], "forward")["f"][0] == 2.0
    assert writer._conn.execute("PRAGMA synchronous").fetchone()[0] == 2  # FULL
    writer.close()
    reader.close()


CHILD = textwrap.dedent("""
    import sys
    import numpy as np
    from frictionid.run import RunStore
    store = RunStore.open(sys.argv[1], sys.argv[2], "f1", resume=True)
    start = store.n_evaluations()
    for i in range(start, start + 100000):
        store.record(np.array([float(i), 0.5]), "forward", {"f": np.full(20000, float(i))})
        print(i, flush=True)
""")


def kill_child_after(run_dir, n_lines):
    """Run CHILD, SIGKILL it after it reported ``n_lines`` committed records; return the last reported index."""
    child = subprocess.Popen([sys.executable, "-c", CHILD, str(run_dir), CONFIG], stdout=subprocess.PIPE, text=True)
    lines = [child.stdout.readline() for _ in range(n_lines)]
    child.send_signal(signal.SIGKILL)
    child.wait(timeout=10)
    child.stdout.close()
    assert child.returncode == -signal.SIGKILL
    return int(lines[-1])


def test_kill_9_during_records_keeps_every_committed_evaluation(tmp_path):
    open_store(tmp_path).close()
    for _ in range(3):  # kill, resume and append, three times over
        last_reported = kill_child_after(tmp_path, 15)
        with sqlite3.connect(tmp_path / "store.sqlite") as conn:
            assert conn.execute("PRAGMA integrity_check").fetchone()[0] == "ok"
        conn.close()
        with open_store(tmp_path, resume=True) as store:
            rows = list(store.evaluations())
            assert len(rows) >= last_reported + 1
            assert [r.x[0] for r in rows] == list(range(len(rows)))  # no gaps, no duplicates
            for r in rows[-3:]:
                np.testing.assert_array_equal(store.lookup(r.x, "forward")["f"], np.full(20000, r.x[0]))
    with open_store(tmp_path, resume=True) as store:
        store.record([-1.0], "forward", {"f": np.zeros(1)})
        assert store.n_evaluations() == len(rows) + 1
