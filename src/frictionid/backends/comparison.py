"""The record of one model solved by both backends: stage-end observations, reactions, zone forces and times."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class CrossCheck:
    """Stage-end results of both backends on one model.

    Attributes
    ----------
    quantities : observed quantities (rows point-major); points : (n, dim) [mm]
    embedded, calculix : (n_stages, n_rows) observations
    reaction_labels : "boundary.x"; reactions_embedded, reactions_calculix : (n_stages, n_reac) [N]
    zone_names; normal_embedded, normal_calculix, tangential_embedded, tangential_calculix : (n_stages, n_zones) [N]
    time_embedded, time_calculix : [s] per forward solve; setup_embedded : [s] condensation (once per geometry)
    derivatives_embedded : (n_stages, n_rows, n_zones), reaction_derivatives_embedded : (n_stages, n_reac, n_zones)
        the embedded backend's sensitivities of observations and reactions at the stage ends
    load_scale : the CalculiX settings' load_scale (1: ccx at the loads as given)
    kind : the model kind ("3d", "plane_strain", "axisymmetric"; "" when not known)
    """

    model_name: str
    n_nodes: int
    mu: np.ndarray
    quantities: tuple[str, ...]
    points: np.ndarray
    embedded: np.ndarray
    calculix: np.ndarray
    reaction_labels: tuple[str, ...]
    reactions_embedded: np.ndarray
    reactions_calculix: np.ndarray
    zone_names: tuple[str, ...]
    normal_embedded: np.ndarray
    normal_calculix: np.ndarray
    tangential_embedded: np.ndarray
    tangential_calculix: np.ndarray
    time_embedded: float
    time_calculix: float
    setup_embedded: float
    penalty: tuple[float, float]
    derivatives_embedded: np.ndarray
    reaction_derivatives_embedded: np.ndarray
    load_scale: float = 1.0
    kind: str = ""
