"""The dense block reference's own generator (tests/fixtures/dense_block/generate.py with benchmarks/tilt_ccx.py's
meshes): a quadratic block's faces are read by their elements' own field, and the contact's slave can be either
body."""

import importlib.util
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
_spec = importlib.util.spec_from_file_location("dense_generate", ROOT / "tests" / "fixtures" / "dense_block"
                                               / "generate.py")
dense = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(dense)
tilt, gen = dense.tilt, dense.tilt.gen


def test_a_quadratic_blocks_faces_are_interpolated_by_its_own_field():
    plate, block, _ = tilt.meshes("g3q")
    assert isinstance(block, tilt.QuadraticGrid) and block.cells.shape[1] == 20
    # a field in the 8-node serendipity space of every face (bilinear, x^2-type and x^2 y-type terms), not bilinear
    field = lambda p: np.column_stack([1 + p[:, 0] ** 2 + p[:, 1] * p[:, 2], p[:, 2] ** 2 - p[:, 1] ** 2,
                                       p[:, 0] * p[:, 1] + p[:, 2] ** 2 * p[:, 0]])
    ids = block.ids.ravel()
    disp = {int(n): v for n, v in zip(ids[ids > 0], field(block.points[ids > 0]))}
    for name, axis, xyz in dense.face_points(0.6)[:4]:
        np.testing.assert_allclose(dense.displacements(plate, block, disp, axis, xyz), field(xyz), atol=1e-10,
                                   err_msg=name)


def test_a_quadratic_plates_top_is_interpolated_by_its_own_field_and_the_ring_is_a_smooth_grading():
    plate, block, _ = tilt.meshes("g3Qr")
    assert isinstance(plate, tilt.QuadraticGrid) and isinstance(block, tilt.QuadraticGrid)
    field = lambda p: np.column_stack([1 + p[:, 0] ** 2 + p[:, 1] * p[:, 0], p[:, 1] ** 2 - 3 * p[:, 0] * p[:, 1],
                                       p[:, 0] ** 2 * p[:, 1] - p[:, 1] ** 2 * p[:, 0] + 0.5 * p[:, 2]])
    ids = plate.ids.ravel()
    disp = {int(n): v for n, v in zip(ids[ids > 0], field(plate.points[ids > 0]))}
    name, axis, xyz = dense.face_points(0.6)[4]
    assert name == "plate"
    np.testing.assert_allclose(dense.displacements(plate, block, disp, axis, xyz), field(xyz), atol=1e-10)
    # the ring's element lines: from the footprint's edge to 20 mm, growing (by less than 3 from one to the next)
    xy = tilt.graded_lines(5, ring=True)[0]
    sizes = np.diff(xy[xy >= 5.0])
    assert xy[-1] == 20.0 and np.all(np.diff(sizes) > 0) and np.all(sizes[1:] / sizes[:-1] < 3.1)
    assert np.count_nonzero((xy > 5.0) & (xy < 10.5)) == 4


def test_the_plate_as_slave_carries_the_zones_on_its_faces_under_the_footprint():
    plate, block, _ = tilt.meshes("g3")
    deck = gen.write_deck(plate, block, 1e7, 1e5, n_press=2, n_pull_min=5, slave="plate")
    lines = deck.splitlines()
    surfaces = {}
    for i, line in enumerate(lines):
        if line.startswith("*SURFACE, NAME="):
            name = line.split("=")[1].split(",")[0]
            surfaces[name] = []
            for l in lines[i + 1:]:
                if l.startswith("*"):
                    break
                surfaces[name].append(l)
    top = plate.ijk[:, 2] == plate.shape[2] - 2
    centres = {int(e): c for e, c in zip(plate.eids[top], plate.centres[top])}
    quadrant = {"A": (-1, -1), "B": (1, -1), "C": (-1, 1), "D": (1, 1)}
    n_under = 0
    for zone, (sx, sy) in quadrant.items():
        faces = surfaces[f"S{zone}"]
        assert all(face.endswith(", S2") for face in faces)
        xy = np.array([centres[int(face.split(",")[0])][:2] for face in faces])
        assert np.all((np.sign(xy) == (sx, sy)) & (np.abs(xy) < 5.0)), zone
        n_under += len(faces)
    inside = [c for c in centres.values() if abs(c[0]) < 5 and abs(c[1]) < 5]
    assert n_under == len(inside)
    assert len(surfaces["SBLOCK"]) == (block.shape[0] - 1) * (block.shape[1] - 1)
    assert "SA, SBLOCK" in lines and "*CONTACT PRINT, SLAVE=SA, MASTER=SBLOCK" in lines


def test_the_cubic_grading_refines_the_edges_as_n_to_the_minus_3_and_keeps_its_ends():
    for n in (3, 4, 8, 16, 32):
        s = tilt.cubic_half_side(n)
        assert s[0] == 0.0 and s[-1] == 5.0 and np.all(np.diff(s) > 0)
        np.testing.assert_allclose(s, 5.0 - s[::-1], atol=1e-12)        # the same grading at both ends
    # the edge element's order: its ratio between n and 2n tends to 8 (1 - cos: 4)
    edge = lambda n: tilt.cubic_half_side(n)[1]
    assert abs(edge(256) / edge(512) - 8.0) < 0.1 and 7.5 < edge(32) / edge(64) < 8.5
    t = np.linspace(0.0, 1.0, 2001)
    h = tilt.cubic_start(t)
    assert h[0] == 0.0 and abs(h[-1] - 1.0) < 1e-12 and np.all(np.diff(h) > 0)
    assert abs(tilt.cubic_start(1e-2) / tilt.cubic_start(5e-3) - 8.0) < 0.1
    # the twin of 1 - cos(pi t / 2) at t = 1: same slope, so ring_map's far piece joins as before
    slope = (tilt.cubic_start(1.0) - tilt.cubic_start(1.0 - 1e-6)) / 1e-6
    assert abs(slope - np.pi / 2) < 1e-4
    ring = tilt.ring_map(np.linspace(0.0, 1.0, 401), cubic=True)
    assert ring[0] == 5.0 and abs(ring[-1] - 20.0) < 1e-12 and np.all(np.diff(ring) > 0)
    np.testing.assert_allclose(tilt.ring_map(np.linspace(0.6, 1.0, 9), cubic=True),
                               tilt.ring_map(np.linspace(0.6, 1.0, 9)), atol=1e-12)
    xy, plate_z, block_z = tilt.graded_lines(4, ring=True, cubic=True)
    assert len(xy) == len(tilt.graded_lines(4, ring=True)[0])              # the same element counts as 1 - cos
    assert plate_z[0] == -5.0 and plate_z[-1] == 0.0 and block_z[0] == 0.0 and block_z[-1] == 10.0
    assert np.diff(plate_z)[-1] < 0.6 * np.diff(tilt.graded_lines(4, ring=True)[1])[-1]


def test_the_convergence_study_extrapolates_a_sequence_of_known_order_to_its_limit():
    """benchmarks/dense_convergence.py's Richardson step on values f(h) = L + C h^p (per kind and stage, each its
    own p): it finds each p and returns L, the finest level's error as L - f(h_c)."""
    import sys
    sys.path.insert(0, str(ROOT / "benchmarks"))
    _conv = importlib.util.spec_from_file_location("dense_convergence", ROOT / "benchmarks" / "dense_convergence.py")
    conv = importlib.util.module_from_spec(_conv)
    _conv.loader.exec_module(conv)
    rng = np.random.default_rng(0)
    truth = {"u": [rng.normal(size=50), rng.normal(size=50)], "e": [rng.normal(size=80), rng.normal(size=80)],
             "force": [np.array([600.0]), np.array([598.0])]}
    slope = {kind: [rng.normal(size=len(v)) for v in truth[kind]] for kind in truth}
    order = {"u": (1.1, 2.0), "e": (0.7, 3.0), "force": (1.5, 1.0)}
    h = [1 / 2, 1 / 3, 1 / 4]
    levels = [{kind: [truth[kind][s] + slope[kind][s] * x ** order[kind][s] for s in (0, 1)] for kind in truth}
              for x in h]
    row, limit = conv.richardson(levels, h)
    for kind in truth:
        for s in (0, 1):
            assert abs(row[f"{kind}{s + 1}"]["order"] - order[kind][s]) < 0.01
            np.testing.assert_allclose(limit[kind][s], truth[kind][s], atol=1e-6 * np.abs(slope[kind][s]).max())
            error = truth[kind][s] - levels[2][kind][s]
            assert abs(row[f"{kind}{s + 1}"]["error_rms"] - np.sqrt(np.mean(error ** 2))) < 2e-3
    two = conv.at_order(levels[1:], h[1:], order["u"][1])             # two levels at the pull's u order
    np.testing.assert_allclose(two["u"][1], truth["u"][1], atol=1e-9)
    assert np.abs(two["u"][0] - truth["u"][0]).max() > 1e-3              # not at the press stage's order
    gap = conv.gap(limit, levels[2])
    assert abs(gap["u2_rms"] - np.sqrt(np.mean((truth["u"][1] - levels[2]["u"][1]) ** 2))) < 2e-3


def test_the_edge_refined_family_splits_only_the_elements_next_to_the_edges_and_the_interface():
    coarse, fine = tilt.edge_lines(1), tilt.edge_lines(2)
    for m, (plate_xy, plate_z, block_xy, block_z) in ((1, coarse), (2, fine)):
        for lines in (plate_xy, block_xy):
            assert {0.0, -5.0, 5.0} <= set(lines) and np.all(np.diff(lines) > 0)
            np.testing.assert_allclose(lines, -lines[::-1], atol=1e-12)
        # the elements next to x = 5 (both sides in the plate, inside in the block) and to z = 0: h / 8^m
        i = int(np.flatnonzero(plate_xy == 5.0)[0])
        np.testing.assert_allclose([5.0 - plate_xy[i - 1], plate_xy[i + 1] - 5.0], [1.0 / 8 ** m] * 2)
        assert abs(5.0 - block_xy[-2] - 0.6 / 8 ** m) < 1e-12
        assert abs(-plate_z[-2] - 1.0 / 8 ** m) < 1e-12 and abs(block_z[1] - 1.0 / 8 ** m) < 1e-12
        # the interface matches only on the zone borders and the edges
        shared = set(np.round(plate_xy, 9)) & set(np.round(block_xy, 9))
        assert shared == {-5.0, 0.0, 5.0}
    # a level adds lines next to the edges only: the coarser level's lines are all kept
    for a, b in zip(coarse, fine):
        assert set(np.round(a, 12)) <= set(np.round(b, 12)) and len(b) - len(a) in (1, 2, 4)
    plate, block, _ = tilt.meshes("e1Qp")
    assert isinstance(plate, tilt.QuadraticGrid) and isinstance(block, tilt.QuadraticGrid)
    assert plate.n_nodes + block.n_nodes == 10230


def test_the_edge_family_with_r_has_the_plate_at_most_0_7_mm_from_the_footprint_past_the_points():
    plain, ring = tilt.edge_lines(2), tilt.edge_lines(2, ring=True)
    out = ring[0][(ring[0] >= 5.0) & (ring[0] <= 10.1)]
    assert out[0] == 5.0 and out[-1] == 10.1 and np.diff(out).max() <= 0.7 + 1e-12
    assert np.diff(plain[0][(plain[0] >= 5.0) & (plain[0] <= 10.1)]).max() > 2.0       # without r: 2.05 mm
    for a, b in zip(ring[1:], plain[1:]):                        # the layers and the block are the same
        np.testing.assert_array_equal(a, b)
    assert tilt.EDGE.fullmatch("e2Qpr") and tilt.meshes("e2Qpr")[0].n_nodes > tilt.meshes("e2Qp")[0].n_nodes


def test_the_acceptance_study_leaves_out_plate_points_and_splits_the_misfit_by_region(tmp_path):
    """benchmarks/dense_acceptance.py's ``--exclude-plate-within``: the plate points nearer than that to the
    footprint are gone and every point kept has its full replicate's noisy values; ``--where``: each observation's
    squared weighted residual lands in its point's region (dense_convergence.regions), the shares add up to 1."""
    import sys
    sys.path.insert(0, str(ROOT / "benchmarks"))
    import dense_acceptance as acceptance
    import dense_convergence as conv
    reference = ROOT / "tests" / "fixtures" / "dense_block" / "measured.csv"
    labels, xyz, values, force = acceptance.read_values(reference)
    assert sorted(np.concatenate([np.flatnonzero(m) for _, m in conv.regions(labels, xyz, by_face=True)])) \
        == list(range(len(labels)))                                           # every point in exactly one region
    (tmp_path / "all").mkdir()
    full = acceptance.read_values(acceptance.write_replicate(3, tmp_path / "all", reference))
    kept = acceptance.read_values(acceptance.write_replicate(3, tmp_path, reference, exclude=2.5))
    near = np.array([l.startswith("plate:") for l in labels]) & (conv.footprint_distance(xyz) < 2.5)
    assert near.sum() > 100 and kept[0] == [l for l, n in zip(labels, near) if not n]
    np.testing.assert_array_equal(kept[2], full[2][:, ~near])
    np.testing.assert_array_equal(kept[3], full[3])
    rng = np.random.default_rng(1)
    points = [labels[i] for i in rng.choice(len(labels), 40, replace=False)]
    observations = [{"label": f"{p}:uz@2", "measured": 0.0, "model": float(rng.normal()), "sigma": 0.5}
                    for p in points] + [{"label": "force@2", "measured": 1.0, "model": 4.0, "sigma": 1.0}]
    rows = acceptance.misfit_where({"fit": {"observations": observations}}, reference)
    uz = [r for r in rows if r["quantity"] == "uz"]
    assert abs(sum(r["share"] for r in uz) - 1.0) < 5e-3 and sum(r["n"] for r in uz) == 40
    residual = {o["label"].rsplit(":", 1)[0]: o["model"] / 0.5 for o in observations[:-1]}
    for name, mask in conv.regions(labels, xyz, by_face=True):
        inside = [residual[l] for l, m in zip(labels, mask) if m and l in residual]
        row = [r for r in uz if r["region"] == name]
        assert len(row) == bool(inside)
        if inside:
            assert row[0]["n"] == len(inside) and abs(row[0]["mean_r2"] - np.mean(np.square(inside))) < 1e-3
    assert {r["region"] for r in rows if r["quantity"] == "force"} == {"machine"}
    assert [r["mean_r2"] for r in rows if r["quantity"] == "force"] == [9.0]
    chi2 = sum(r["mean_r2"] * r["n"] for r in uz)
    assert abs(chi2 - sum((o["model"] / 0.5) ** 2 for o in observations[:-1])) < 1e-2 * chi2


def _benchmark(name):
    import sys
    sys.path.insert(0, str(ROOT / "benchmarks"))
    return importlib.import_module(name)


def test_the_splitting_estimate_of_a_model_against_the_reference_adds_its_directions():
    """benchmarks/dense_convergence.py ``--splitting P``: a model whose error is C_1 + C_2, each direction
    refined by 2 dividing its own term by 2^p, gets the estimate C_1 + C_2 at order p (nothing left over) and a
    wrong one at another order; the block faces' mean uz is the ``sink``."""
    conv = _benchmark("dense_convergence")
    rng = np.random.default_rng(3)
    labels = [f"y-5:{k}" for k in range(6)] + [f"plate:{k}" for k in range(4)]
    noise = dense.NOISE_U
    reference = rng.normal(size=(2, 10, 9))
    c1, c2 = (rng.normal(size=(2, 10, 9)) * noise for _ in range(2))
    model = reference + c1 + c2
    refined = [reference + c1 / 4 + c2, reference + c1 + c2 / 4]          # p = 2
    row = conv.splitting([reference, model, *refined], labels, 2.0)
    for component, axis in (("ux", 0), ("uy", 1), ("uz", 2)):
        actual = (c1 + c2)[:, :, axis] / noise
        assert abs(row[f"{component}_actual"] - np.sqrt(np.mean(actual ** 2))) < 1e-3
        assert abs(row[f"{component}_estimate"] - row[f"{component}_actual"]) < 2e-3
        assert row[f"{component}_left"] < 1e-3
    assert abs(row["sink_pull_actual"] - np.mean((c1 + c2)[1, :6, 2]) / noise) < 1e-3
    assert row["sink_pull_left"] == 0.0
    assert conv.splitting([reference, model, *refined], labels, 1.0)["uz_left"] > 0.1


def test_the_block_pieces_benchmark_splits_only_its_piece_outside_the_bands():
    """benchmarks/block_pieces.py: ``plate_z`` splits the plate's layers outside the interface band, ``outer`` the
    plate's intervals outside the footprint and the edge band; everything else of the layout is kept."""
    pieces = _benchmark("block_pieces")
    from frictionid.builders import block_mesh
    from frictionid.builders.block_mesh import Bands, _graded
    bands = Bands(edge_splits=4, edge_band=0.5, interface_splits=4)
    given = block_mesh.layout(10, 10, 5, 4.0, bands)
    outer = pieces.split_layout(block_mesh.layout, {"outer": 2})(10, 10, 5, 4.0, bands)
    plate = pieces.split_layout(block_mesh.layout, {"plate_z": 3})(10, 10, 5, 4.0, bands)
    band = given.outer < 5.0 + 0.5                                 # the edge band's nodes (and the edge) stay
    assert set(np.round(given.outer, 9)) <= set(np.round(outer.outer, 9))
    np.testing.assert_array_equal(outer.outer[outer.outer < 5.5], given.outer[band])
    assert len(outer.outer) - len(given.outer) == len(given.outer) - band.sum()
    np.testing.assert_array_equal(outer.quarter, given.quarter)
    z0, z1 = (5.0 * _graded(g, 4.0, both_ends=False) for g in (given.plate_z, plate.plate_z))
    outside = int(np.sum((z0[:-1] + z0[1:]) / 2 >= 1.0))
    assert len(z1) - len(z0) == 2 * outside and np.allclose(z1[z1 < 1.0], z0[z0 < 1.0])
    for name in ("quarter", "block_z", "outer"):
        np.testing.assert_array_equal(getattr(plate, name), getattr(given, name))
    assert plate.n_nodes() > given.n_nodes() and outer.n_nodes() > given.n_nodes()


def test_the_acceptance_study_states_the_noise_of_the_observed_kinds_only(tmp_path):
    """benchmarks/dense_acceptance.py's configs: each mode's [data] states the noise of the kinds it observes and no
    other (a noise stated for an unobserved kind is noted by the config check), and the no-force modes observe
    no force."""
    import sys
    import tomllib
    sys.path.insert(0, str(ROOT / "benchmarks"))
    import dense_acceptance as acceptance
    kinds = {"u": ("ux", "uy", "uz"), "e": ("exx", "eyy", "ezz", "exy", "eyz", "exz"), "force": ("force",)}
    for mode, (observables, model_error) in acceptance.MODES.items():
        text = acceptance.config_text(tmp_path / "data.csv", acceptance.OBSERVABLES[observables], model_error,
                                      tmp_path / "run", 5.0, dict.fromkeys(acceptance.TRUTH, 0.1))
        data = tomllib.loads(text)["data"]
        observed = {kind for kind, names in kinds.items() if set(names) & set(data["observables"])}
        assert set(data["noise"]) == observed, mode
        assert ("force" in data["observables"]) == ("no-force" not in mode), mode
