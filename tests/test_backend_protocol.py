"""Both backends meet the Backend protocol, and the modules above backends/ name the protocol, not a backend."""

import re
import shutil
from pathlib import Path

import numpy as np
import pytest

from frictionid.backends import Backend, make_backend
from frictionid.options import SolverOptions
from frictionid.backends.base import Prediction

SRC = Path(__file__).parents[1] / "src" / "frictionid"


def test_the_embedded_backend_is_a_backend_and_predicts_a_prediction(block2d):
    points = block2d.mesh.points[[0, len(block2d.mesh.points) // 2]]
    backend = make_backend(block2d, points, ("ux", "uy"))
    assert isinstance(backend, Backend)
    prediction = backend.predict(np.full(len(block2d.zone_names), 0.2), sensitivities=True)
    assert isinstance(prediction, Prediction)
    assert prediction.values.shape == (block2d.n_stages, 4)
    assert prediction.derivatives.shape == (block2d.n_stages, 4, len(block2d.zone_names))


@pytest.mark.skipif(shutil.which("ccx") is None, reason="needs ccx (CalculiX) on PATH")
def test_the_calculix_backend_is_a_backend(block2d):
    backend = make_backend(block2d, block2d.mesh.points[:1], ("ux",), solver=SolverOptions(backend="calculix"))
    assert isinstance(backend, Backend) and not backend.has_sensitivities


def test_an_object_without_predict_is_not_a_backend():
    class NoPredict:
        name, has_sensitivities, model = "x", False, None

    assert not isinstance(NoPredict(), Backend)


def test_only_the_backend_registry_and_the_modules_that_build_the_embedded_solver_name_it():
    """The identification's layer types its backends with the protocol; EmbeddedBackend is imported only where
    the embedded solver itself is built (the discretisation control and the model-error estimate, planning's sensitivities, the bolt study)."""
    importers = sorted(str(path.relative_to(SRC)) for path in SRC.rglob("*.py")
                       if re.search(r"import .*\bEmbeddedBackend\b", path.read_text())
                       and "backends" not in path.parts)
    assert importers == ["inverse/discretisation_control.py", "inverse/model_error.py", "planning.py",
                         "studies/bolt.py"]
