"""Embedded backend: a condensation is reused only for a model and points equal in content."""

import dataclasses

import numpy as np

from frictionid.backends.embedded import EmbeddedBackend
from frictionid.builders.block import block_model_2d
from frictionid.model import Material
from frictionid.options import ModelSpec

POINTS = np.array([[-5.0, 2.0], [5.0, 2.0]])


def test_fingerprint_tells_models_apart_by_content():
    a, b = block_model_2d(mesh_size=2.0), block_model_2d(mesh_size=2.0)
    assert a is not b and a.fingerprint() == b.fingerprint()
    changed = [block_model_2d(mesh_size=2.0, pull=0.3), block_model_2d(mesh_size=2.5),
               dataclasses.replace(a, materials={**a.materials, "block": Material(70000.0, 0.33)})]
    assert len({a.fingerprint(), *(m.fingerprint() for m in changed)}) == 4


def test_equal_models_and_points_share_one_condensation_and_give_equal_results():
    first = EmbeddedBackend(block_model_2d(mesh_size=2.0), POINTS, ("ux", "uy"), ["block"] * 2)
    again = EmbeddedBackend(block_model_2d(mesh_size=2.0), POINTS.copy(), ("ux", "uy"), ["block"] * 2)
    assert again.problem is first.problem
    other = EmbeddedBackend(block_model_2d(mesh_size=2.0), POINTS - [[-0.5, 0.5], [0.5, 0.5]], ("ux", "uy"), ["block"] * 2)
    assert other.problem is not first.problem
    fresh = EmbeddedBackend(block_model_2d(mesh_size=2.0, pull=0.3), POINTS, ("ux", "uy"), ["block"] * 2)
    assert fresh.problem is not first.problem
    mu = np.array([0.2, 0.3])
    np.testing.assert_array_equal(first.predict(mu).values, again.predict(mu).values)


def test_the_least_recently_used_condensation_is_dropped_first():
    def backend(pull):
        return EmbeddedBackend(block_model_2d(mesh_size=2.5, pull=pull), POINTS, ("uy",), ["block"] * 2)

    a, b = backend(0.1), backend(0.2)
    assert backend(0.1).problem is a.problem          # a is now the most recent
    backend(0.3)                                      # evicts b
    assert backend(0.1).problem is a.problem and backend(0.2).problem is not b.problem


def test_a_cache_folder_keeps_condensations_and_solves_for_a_later_session(tmp_path, monkeypatch, caplog):
    import pickle

    import frictionid.backends.embedded as embedded
    from frictionid.fem.problem import Problem

    embedded.use_cache(tmp_path)
    try:
        monkeypatch.setattr(embedded, "_RECENT", {})
        model = block_model_2d(mesh_size=2.0, order=1)
        mu = np.array([0.2, 0.3])
        first = EmbeddedBackend(model, POINTS, ("ux", "exx"), ["block"] * 2)
        solved = first.predict(mu, sensitivities=True)
        assert len(list(tmp_path.glob("condensed-*.pkl"))) == 1 and len(list(tmp_path.glob("predicted-*.npz"))) == 1
        monkeypatch.setattr(embedded, "_RECENT", {})                # a new session: only the folder is left

        def no_build(*args, **kwargs):
            raise AssertionError("built again although the cache holds it")

        monkeypatch.setattr(Problem, "build", no_build)
        again = EmbeddedBackend(block_model_2d(mesh_size=2.0, order=1), POINTS, ("ux", "exx"), ["block"] * 2)
        assert again.problem is not first.problem
        replayed = again.predict(mu, sensitivities=True)
        assert np.array_equal(replayed.values, solved.values)
        assert np.array_equal(replayed.derivatives, solved.derivatives)
        other = np.array([0.25, 0.3])                               # a new solve with the read condensation
        assert np.allclose(again.predict(other).values, first.predict(other).values, rtol=0, atol=1e-14)
        monkeypatch.undo()
        # a truncated file is built again with a warning; a changed model never reads another's file
        embedded.use_cache(tmp_path)
        monkeypatch.setattr(embedded, "_RECENT", {})
        path = next(tmp_path.glob("condensed-*.pkl"))
        path.write_bytes(path.read_bytes()[:100])
        with caplog.at_level("WARNING"):
            rebuilt = EmbeddedBackend(model, POINTS, ("ux", "exx"), ["block"] * 2)
        assert "unreadable" in caplog.text
        assert isinstance(pickle.loads(path.read_bytes()), Problem)
        assert np.array_equal(rebuilt.predict(mu).values, solved.values)
        EmbeddedBackend(block_model_2d(mesh_size=2.0, order=1, pull=0.3), POINTS, ("ux", "exx"), ["block"] * 2)
        assert len(list(tmp_path.glob("condensed-*.pkl"))) == 2
    finally:
        embedded.use_cache(None)


def test_equal_model_tables_share_one_built_model_and_others_do_not():
    from frictionid.builders.registry import build_model

    first = build_model(ModelSpec.from_table({"builder": "block2d", "mesh_size": 2.0, "n_zones": 3}))
    assert build_model(ModelSpec.from_table({"n_zones": 3, "mesh_size": 2.0, "builder": "block2d"})) is first
    assert build_model(ModelSpec.from_table({"builder": "block2d", "mesh_size": 2.0, "n_zones": 2})) is not first
