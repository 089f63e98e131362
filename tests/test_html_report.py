"""report.html: self-contained, complete, also for a stopped run, and rendered by a real headless Chromium."""

import hashlib
import html
import json
import re
import shutil
import subprocess
from importlib.metadata import version
from pathlib import Path

import numpy as np
import pytest
from matplotlib.lines import Line2D

from block2d_case import POINTS, TRUE
from frictionid.cli import main
from frictionid.report.outputs import convergence_figure, error_bar, write_outputs
from frictionid.run.store import RunStore

CONFIG = """[model]
builder = "block2d"
mesh_size = 1.0
height = 4.0
n_zones = 3
[friction]
zones = {zones}
{fixed}
[data]
file = "{data}"
observables = ["ux", "uy"]
stages = [2]
noise = {{ u = 0.0005 }}
regions = {{ P1 = "block", P2 = "block", P3 = "block", P4 = "block", P5 = "base", P6 = "base" }}
[run]
dir = "runs/report"
"""


def _chromium() -> str | None:
    """The system's Chromium (Debian package `chromium`), if installed."""
    return next((path for path in ("/usr/bin/chromium", shutil.which("chromium"), shutil.which("chromium-browser"))
                 if path and Path(path).exists()), None)


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    """A plane-strain block fitted for A and B with C fixed (data simulated at TRUE on the same mesh)."""
    folder = tmp_path_factory.mktemp("html")
    (folder / "points.csv").write_text(POINTS)
    (folder / "truth.toml").write_text(CONFIG.format(zones="{ A = 0.32, B = 0.18, C = 0.41 }", fixed="",
                                                     data="points.csv"))
    assert main(["simulate", str(folder / "truth.toml"), "--out", str(folder / "measured.csv")]) == 0
    (folder / "fit.toml").write_text(CONFIG.format(zones="{ A = 0.1, B = 0.1 }", fixed="fixed = { C = 0.41 }",
                                                   data="measured.csv"))
    assert main(["identify", str(folder / "fit.toml")]) == 0
    return folder


def test_report_holds_coefficients_verdicts_fit_and_provenance_in_one_file(run):
    result = json.loads((run / "runs/report/result.json").read_text())
    page = (run / "runs/report/report.html").read_text()
    for name, p in result["parameters"].items():
        assert f"{p['value']:.6f}" in page, name
    a, b = result["parameters"]["A"], result["parameters"]["B"]
    assert f"[{a['ci95'][0]:.4f}, {a['ci95'][1]:.4f}]" in page
    verdicts = re.findall(r"<td class=\"text\">(?:<span class=\"\w+\">)?(resolved|NOT RESOLVED|fixed)<", page)
    assert verdicts == [("resolved" if p["identifiable"] else "NOT RESOLVED") for p in (a, b)] + ["fixed"]
    # data simulated on the fit's own mesh carry no noise: far below the stated noise, never "explained"
    assert html.escape(a["why"]) in page and "SMALLER THAN THE STATED NOISE ALLOWS" in page
    assert "the stated noise explains the misfit" not in page and "its 1 % quantile" in page
    observations = result["fit"]["observations"]
    assert [o["label"] for o in observations] == [f"P{k}:{q}@2" for q in ("ux", "uy") for k in range(1, 7)]
    assert all(o["model"] == pytest.approx(o["measured"], abs=1e-9) and o["sigma"] == 0.0005 for o in observations)
    assert hashlib.sha256((run / "measured.csv").read_bytes()).hexdigest() in page
    assert "fixed = { C = 0.41 }" in page                          # the config text
    for package in ("frictionid", "numpy", "scipy", "scikit-fem"):
        assert f"<td class=\"text\">{package}</td><td class=\"text\">{version(package)}</td>" in page
    for title in ("Convergence", "Measured and fitted", "Residual map", "Identifiability", "Solver statistics"):
        assert f"<h2>{title}</h2>" in page


def test_report_refers_to_nothing_outside_itself(run):
    page = (run / "runs/report/report.html").read_text()
    assert not re.search(r"(?:src|href)\s*=\s*[\"']?\s*(?:https?:)?//", page, re.IGNORECASE)
    assert "<script" not in page and "<link" not in page and "url(" not in page
    sources = re.findall(r"<img[^>]*\ssrc=\"([^\"]*)\"", page)
    assert len(sources) == 3 and all(s.startswith("data:image/png;base64,") for s in sources)


def test_convergence_plot_shows_free_zones_on_integer_iterations_with_errors_and_truth(run):
    result = json.loads((run / "runs/report/result.json").read_text())
    fig = convergence_figure({**result, "truth": TRUE})
    right = fig.axes[1]
    assert [t.get_text() for t in right.get_legend().get_texts()] == ["A", "B"]     # C is fixed
    ticks = right.get_xticks()
    assert np.allclose(ticks, np.round(ticks))
    dashed = sorted(line.get_ydata()[0] for line in right.lines if line.get_linestyle() == "--")
    assert dashed == [TRUE["B"], TRUE["A"]]
    bars = [c for c in right.containers if c.has_yerr]
    final = [result["parameters"][z]["stderr"] for z in ("A", "B")]
    assert [bar.lines[2][0].get_segments()[0][1, 1] - bar.lines[2][0].get_segments()[0][0, 1] for bar in bars] == \
        pytest.approx([2 * s for s in final])
    # a zone on its lower bound 0: the bar stops there (a negative coefficient is no friction)
    assert error_bar(0.0, {"stderr": 0.4, "ci95": [0.0, 0.66]}) == [[0.0], [0.4]]
    assert error_bar(0.9, {"stderr": 0.4, "ci95": [0.2, 1.0]}) == [[0.4], [pytest.approx(0.1)]]


def test_a_stopped_run_gets_a_report_of_what_exists(tmp_path):
    """An interrupted run's result has no fit: the report says so and shows the stored iterations."""
    data = tmp_path / "data.csv"
    data.write_text(POINTS)
    store = RunStore.open(tmp_path, "config text", "fingerprint", resume=False)
    store.record_iteration(0, np.array([0.1, 0.1]), 12.0)
    store.record_iteration(1, np.array([0.3, 0.2]), 0.5)
    result = {"status": "interrupted", "message": "stopped by the user; continue with --resume", "method": "trf",
              "jacobian": "analytic", "backend": "embedded", "n_iterations": 1, "n_forward_solves": 0,
              "n_sensitivity_solves": 2, "n_replayed": 0, "wall_time_s": 1.5,
              "parameters": {"A": {"value": 0.3, "initial": 0.1, "fixed": False},
                             "B": {"value": 0.2, "initial": 0.1, "fixed": False},
                             "C": {"value": 0.41, "initial": 0.41, "fixed": True}}}
    paths = write_outputs(tmp_path, result, store, "[run]\n", data)
    store.close()
    assert [p.name for p in paths] == ["result.json", "history.csv", "convergence.png", "report.html"]
    assert (tmp_path / "history.csv").read_text().splitlines()[1:] == ["0,12.0,0.1,0.1,0.41", "1,0.5,0.3,0.2,0.41"]
    page = (tmp_path / "report.html").read_text()
    assert "interrupted" in page and "continue with --resume" in page and "not computed" in page
    assert "0.300000" in page and hashlib.sha256(data.read_bytes()).hexdigest() in page
    assert page.count("data:image/png;base64,") == 1                # the convergence plot, from the store


def _browser(chromium: str, profile: Path, *arguments: str) -> subprocess.CompletedProcess:
    # no network: every host name fails to resolve, so only what the file holds can show
    flags = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-background-networking",
             "--disable-component-update", "--no-first-run", "--disable-sync", f"--user-data-dir={profile}",
             "--host-resolver-rules=MAP * ~NOTFOUND"]
    return subprocess.run([chromium, *flags, *arguments], capture_output=True, text=True, timeout=120, check=True)


@pytest.mark.skipif(_chromium() is None, reason="Chromium not installed (Debian: apt-get install chromium; "
                                                 ".ci/run installs it)")
def test_headless_chromium_renders_the_tables_and_decodes_every_figure(run, tmp_path):
    """The report without scripts, probed by a copy with one script appended that records each image's decoded
    width once the page has loaded (0 for an image the browser could not show)."""
    chromium = _chromium()
    page = (run / "runs/report/report.html").read_text()
    probe = tmp_path / "probe.html"
    probe.write_text(page.replace("</body>", "<script>window.addEventListener('load', () => document.body."
                                             "setAttribute('data-widths', Array.from(document.images, i => "
                                             "i.naturalWidth).join(',')));</script></body>"))
    dom = _browser(chromium, tmp_path / "profile", "--virtual-time-budget=10000", "--dump-dom",
                   probe.as_uri()).stdout
    widths = re.search(r'data-widths="([^"]*)"', dom)
    assert widths, "the page did not finish loading"
    assert [int(w) for w in widths.group(1).split(",")] == [1000, 1000, 700]   # 100 dpi: 10, 10 and 7 inches wide
    result = json.loads((run / "runs/report/result.json").read_text())
    assert re.search(r"<td class=\"text\">A</td><td>" + f"{result['parameters']['A']['value']:.6f}", dom)
    screenshot = tmp_path / "report.png"
    _browser(chromium, tmp_path / "profile", "--window-size=1280,3000", f"--screenshot={screenshot}",
             (run / "runs/report/report.html").as_uri())
    from PIL import Image
    pixels = np.asarray(Image.open(screenshot).convert("RGB")).astype(int)
    # matplotlib's first colour (C0, #1f77b4) is in every plot and nowhere in the page's own styles
    blue = np.abs(pixels - [0x1F, 0x77, 0xB4]).max(axis=2) < 40
    assert pixels.shape[:2] == (3000, 1280) and blue.sum() > 2000
