"""frictionid: identify zone-wise Coulomb friction coefficients from measured displacements and strains.

The Python interface (the command line ``frictionid`` is a thin layer over it)::

    from frictionid import Parameter, Parameters, identify
    params = Parameters([Parameter("A", 0.1, max=0.6), Parameter("B", 0.1)])
    result = identify({"builder": "block2d"}, "measured.csv", params, observables=["ux", "uy"], stages=[2],
                      noise={"u": 5e-4})
    print(result.fit_report())

The names below are imported on first use, so that ``import frictionid`` (and the command line) stays fast.
"""

import importlib

__version__ = "0.1.0"

#: public name -> module that owns it
_EXPORTS = {
    "identify": "frictionid.identification", "identify_config": "frictionid.identification",
    "IdentificationResult": "frictionid.result",
    "Parameter": "frictionid.inverse.parameters", "Parameters": "frictionid.inverse.parameters",
    "Config": "frictionid.config", "read_config": "frictionid.config", "config_from_dict": "frictionid.config",
    "Measurements": "frictionid.data.measurements", "read_measurements": "frictionid.data.measurements",
    "write_measurements": "frictionid.data.measurements",
    "Model": "frictionid.model", "build_model": "frictionid.builders.registry", "ModelSpec": "frictionid.options",
    "block_model": "frictionid.builders.block", "block_model_2d": "frictionid.builders.block",
    "bolt_model": "frictionid.builders.bolt",
    "simulate": "frictionid.simulation",
    "InputError": "frictionid.errors", "SolverError": "frictionid.errors",
}

__all__ = ["__version__", *_EXPORTS]


def __getattr__(name: str):
    if name in _EXPORTS:
        return getattr(importlib.import_module(_EXPORTS[name]), name)
    raise AttributeError(f"module 'frictionid' has no attribute {name!r}")


def __dir__():
    return sorted(__all__)
