"""frictionid draws its figures with matplotlib's object API: importing it or writing a figure leaves the backend a
user chose, and pyplot, alone (in a subprocess, so that this test session's matplotlib state does not count)."""

import subprocess
import sys

MODULES = ("frictionid.cli", "frictionid.crosscheck", "frictionid.identification", "frictionid.report.bolt",
           "frictionid.report.outputs", "frictionid.studies.block", "frictionid.studies.bolt")
RESULT = {"method": "trf", "jacobian": "analytic", "parameters": {"A": {"fixed": False, "stderr": None}},
          "history": {"objective": [1.0, 0.5], "coefficients": [[0.1], [0.2]]}}

CODE = f"""
import io, sys
import matplotlib
matplotlib.use("svg")        # a backend frictionid would never choose itself
import {", ".join(MODULES)}
imported = matplotlib.get_backend()
from frictionid.report.outputs import convergence_figure, save
stream = io.BytesIO()
save(convergence_figure({RESULT!r}), stream)
print(imported, matplotlib.get_backend(), "matplotlib.pyplot" in sys.modules, stream.getvalue()[:4] == b"\\x89PNG")
"""


def test_importing_and_plotting_keep_the_users_backend_and_leave_pyplot_unloaded():
    run = subprocess.run([sys.executable, "-c", CODE], capture_output=True, text=True, timeout=300)
    assert run.returncode == 0, run.stderr
    assert run.stdout.split() == ["svg", "svg", "False", "True"]
