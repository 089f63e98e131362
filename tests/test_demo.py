"""`frictionid demo --quick`: the M20 study end to end on coarse meshes (what `make demo` runs, finer)."""

import json
import re

import pytest

from frictionid.cli import main
from frictionid.studies.bolt import TRUE_MU

#: issue 4 acceptance: the coefficients the noise-free twin data resolve are recovered within 0.02
RESOLVED_TOL = 0.02


@pytest.fixture(scope="module")
def demo(tmp_path_factory):
    out = tmp_path_factory.mktemp("demo")
    assert main(["demo", "--quick", "--out", str(out)]) == 0
    return out


def test_demo_writes_its_results(demo):
    for name in ("table.txt", "fig9.png", "load_shares.png", "bolt.txt", "mesh_sequence.txt", "measured.csv",
                 "measured_exact.csv", "summary.json", "runs/trf/result.json", "runs/paper/history.csv"):
        assert (demo / name).stat().st_size > 0, name
    assert "Sopwith fit lam P" in (demo / "bolt.txt").read_text()


def test_noise_free_twin_recovers_what_the_data_resolve_and_flags_the_rest(demo):
    result = json.loads((demo / "runs/trf/result.json").read_text())
    resolved = [z for z in TRUE_MU if result["parameters"][z]["identifiable"]]
    assert resolved, "the ten flank points resolve the first section's zones (A, D) at the model-error level"
    for zone in resolved:
        assert abs(result["parameters"][zone]["value"] - TRUE_MU[zone]) < RESOLVED_TOL, zone
    unresolved = [z for z in TRUE_MU if z not in resolved]
    assert unresolved, "ten points cannot resolve six zones: the report must say which"
    prefit = result["identifiability"]["prefit"]
    assert set(unresolved) <= {z for z, ok in prefit["resolved"].items() if not ok}
    assert prefit["suggestions"], "the report must say which extra points would resolve them"


def test_dic_noise_resolves_nothing_and_says_so(demo):
    result = json.loads((demo / "runs/trf-noisy-uy/result.json").read_text())
    assert not any(result["parameters"][z]["identifiable"] for z in TRUE_MU)
    table = (demo / "table.txt").read_text()
    assert table.count("?") >= 6


def test_a_second_demo_into_the_same_folder_needs_resume(demo, capsys):
    assert main(["demo", "--quick", "--out", str(demo)]) == 2
    err = capsys.readouterr().err
    assert "--resume" in err and "trf" in err and "Traceback" not in err


def test_out_must_be_a_folder(tmp_path, capsys):
    (tmp_path / "file").write_text("")
    assert main(["demo", "--quick", "--out", str(tmp_path / "file")]) == 2
    assert "expected a folder" in capsys.readouterr().err


def test_table_flags_zones_on_a_bound_and_no_interval_holds_negative_friction(demo):
    """table.txt: value [95 % interval] per run and zone; a value that prints as a bound carries 'b'."""
    cells = re.findall(r"(\d\.\d{4}) \[(?:(-?\d\.\d{4}), (-?\d\.\d{4})|not seen)\]( [b?]+)?",
                       (demo / "table.txt").read_text())
    assert len(cells) == 4 * len(TRUE_MU)
    for value, low, high, flags in cells:
        assert value not in ("0.0000", "1.0000") or "b" in flags, (value, flags)
        assert low == "" or 0.0 <= float(low) <= float(value) <= float(high) <= 1.0, (value, low, high)
    for run in ("trf", "paper", "trf-noisy", "trf-noisy-uy"):
        result = json.loads((demo / f"runs/{run}/result.json").read_text())
        assert all(p["ci95"][0] >= 0.0 for p in result["parameters"].values() if p.get("ci95")), run
        assert result["truth"] == TRUE_MU and (demo / f"runs/{run}/report.html").stat().st_size > 10000
