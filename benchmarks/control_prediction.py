"""The discretisation control's prediction against actually refined models: the control on a config's data
(target 0.5, budget 2, at the start values), then the values of the model it chose, and of any other refinement
named, condensed and solved at the same start values. The change from the model as given is printed per quantity
kind as RMS in noise levels: the actual change, the change the control predicts (its error as given minus its
error after the refinement, at its orders) and what the prediction misses (RMS of predicted minus actual).

Run (from the config's folder): PYTHONPATH=<repo>/src <repo>/.venv/bin/python <repo>/benchmarks/control_prediction.py
     CONFIG MAX_MEMORY [FACTORS ...]     (FACTORS: one per refinement direction, comma-separated, e.g. 1,1,2,4)
"""

import json
import sys
import time

import numpy as np

from frictionid.builders.registry import build_model
from frictionid.config import read_config
from frictionid.fem import memory
from frictionid.inverse.discretisation_control import control, directions, kind_rms, refinement, values
from frictionid.inverse.model_error import observation_kinds
from frictionid.preparation import prepare, strain_window


def _rms(change, obs, kinds) -> dict:
    return {kind: round(value, 3) for kind, value in kind_rms(np.abs(change) / obs.sigma, kinds).items()}


def main(path: str, max_memory: float, others: list[str]) -> None:
    setup = prepare(read_config(path), echo=lambda text: None)
    obs, spec = setup.observations, setup.model_options
    mu, window = setup.parameters.full(setup.parameters.x0), strain_window(setup.window, obs)
    chosen = control(spec, setup.model, obs, mu, 0.5, 2, max_memory, print, window, "embedded")
    record, kinds = chosen.record, observation_kinds(obs)
    print(json.dumps({key: record.get(key) for key in ("status", "factors", "n_nodes", "error_as_given",
                                                       "predicted_error", "predicted_error_slow", "seconds")}))
    coarse = values(setup.model, obs, mu, window)
    names = directions(spec)
    factors = [tuple(int(k) for k in text.split(",")) for text in others]
    chosen_factors = tuple(record["factors"][name] for name in names)
    for k in [chosen_factors, *factors]:
        if all(f == 1 for f in k):
            continue
        begun = time.perf_counter()
        model = chosen.model if k == chosen_factors else build_model(refinement(spec, k), "[model] (refined)")
        actual = coarse - values(model, obs, mu, window)
        predicted = chosen.given.nominal - chosen.predicted(k)
        print(f"refinement {dict(zip(names, k))} ({model.mesh.n_nodes:,} nodes, {time.perf_counter() - begun:.0f} s): "
              f"actual change {_rms(actual, obs, kinds)}, predicted {_rms(predicted, obs, kinds)}, "
              f"missed by {_rms(predicted - actual, obs, kinds)}", flush=True)
    print(f"process peak {memory.process_peak() / memory.GB:.2f} GB")


if __name__ == "__main__":
    main(sys.argv[1], float(sys.argv[2]), sys.argv[3:])
