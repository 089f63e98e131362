"""The dense independent CalculiX reference (tests/fixtures/dense_block, issue 25 item 4): what its README states
about it holds for the committed files."""

from pathlib import Path

import numpy as np
import pytest

from frictionid.data.measurements import read_measurements
from frictionid.fem.points import window_gradients

FIXTURE = Path(__file__).parent / "fixtures" / "dense_block"
#: the VSG window the README states [mm] (circle diameter)
WINDOW = 2.0
IN_PLANE = {"x": ("eyy", "ezz", "eyz"), "y": ("exx", "ezz", "exz"), "plate": ("exx", "eyy", "exy")}
AXIS = {"x": 0, "y": 1, "z": 2}


@pytest.fixture(scope="module")
def data():
    return read_measurements(FIXTURE / "measured.csv")


def test_dense_points_on_the_faces_a_camera_sees(data):
    face = np.array([p.split(":")[0] for p in data.points])
    assert len(set(data.points)) >= 1500
    assert set(face) == {"x-5", "x+5", "y-5", "y+5", "plate"}
    for name in set(face):
        rows = face == name
        seen = IN_PLANE["plate" if name == "plate" else name[0]]
        for q in ("exx", "eyy", "ezz", "exy", "eyz", "exz"):
            given = ~np.isnan(data.values[q][rows]) if q in data.values else np.zeros(rows.sum(), bool)
            assert given.all() if q in seen else not given.any(), (name, q)


def test_the_strains_are_the_stated_window_of_the_displacements(data):
    """Each point's strains are the least-squares plane fit of its face's displacements within a 2 mm circle:
    recomputed with frictionid's own window operator from the file's (7-digit) displacements."""
    face = np.array([p.split(":")[0] for p in data.points])
    for stage in (1, 2):
        for name in sorted(set(face)):
            rows = np.flatnonzero((face == name) & (data.stage == stage))
            xyz = data.coordinates[rows]
            gradient, _ = window_gradients(xyz, WINDOW, shape="circle")
            u = np.column_stack([data.values[q][rows] for q in ("ux", "uy", "uz")])
            for q in IN_PLANE["plate" if name == "plate" else name[0]]:
                a, b = AXIS[q[1]], AXIS[q[2]]
                expected = 0.5 * (gradient[b] @ u[:, a] + gradient[a] @ u[:, b])
                np.testing.assert_allclose(data.values[q][rows], expected, rtol=0, atol=2e-7, err_msg=f"{name} {q}")
