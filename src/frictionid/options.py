"""The options of a config, one frozen object per table, made once by config.py after it has checked every key,
type and range: what the backends, builders, data readers and the inverse layer receive instead of tables.

The fields and their defaults are the tables' keys (docs/config.md); ``table()`` gives the table back (for
fingerprints, result.json and the config text). The ``[friction]`` table becomes
:class:`frictionid.inverse.parameters.Parameters` once the model's zones are known.
"""

from __future__ import annotations

from dataclasses import MISSING, dataclass, field, fields, replace
from types import MappingProxyType
from typing import Any

#: the bounds of a friction coefficient when none are given ([friction] bounds, :class:`~frictionid.inverse.
#: parameters.Parameter`, the Python API's dict of start values)
DEFAULT_BOUNDS = (0.0, 1.0)


class _Table:
    """What the option objects share: made from a checked table, and turned back into one. The objects are
    frozen; the tables inside them (noise, transform, the method's options, ...) are the config's own, not
    copied, and nothing changes them."""

    def __post_init__(self):
        for f in fields(self):              # a whole number where a float is meant ("tol = 1") becomes a float
            value = getattr(self, f.name)
            if f.type in ("float", "float | None") and isinstance(value, int) and not isinstance(value, bool):
                object.__setattr__(self, f.name, float(value))

    @classmethod
    def from_table(cls, table: dict):
        """The object of a table whose keys config.py has checked (an unknown key is a TypeError here)."""
        return cls(**table)

    def table(self) -> dict:
        """The table: every key with its value (defaults included)."""
        return {f.name: getattr(self, f.name) for f in fields(self)}

    def with_values(self, **changes):
        """A copy with ``changes``."""
        return replace(self, **changes)


@dataclass(frozen=True)
class ModelSpec:
    """The [model] table: the builder's name, its keyword options (checked against the builder's signature by
    :func:`frictionid.builders.registry.build_model`) and the zones merged into one coefficient
    (``[friction] merge``: a refined model merges alike).

    >>> spec = ModelSpec.from_table({"builder": "block2d", "mesh_size": 1.0})
    >>> spec.builder, spec.option("mesh_size"), spec.with_options(mesh_size=0.5).table()
    ('block2d', 1.0, {'builder': 'block2d', 'mesh_size': 0.5})
    """

    builder: str | None
    keywords: Any = field(default_factory=dict)
    merge: Any = None

    def __post_init__(self):
        object.__setattr__(self, "keywords", MappingProxyType(dict(self.keywords)))
        if self.merge:
            object.__setattr__(self, "merge", MappingProxyType(dict(self.merge)))

    @classmethod
    def from_table(cls, table: dict, merge: dict | None = None) -> ModelSpec:
        """From a [model] table (``builder`` plus the builder's options; a ``merge`` key is taken as
        ``[friction] merge``)."""
        table = dict(table)
        builder, merge = table.pop("builder", None), table.pop("merge", None) or merge
        return cls(builder, table, merge or None)

    def option(self, key: str, default=None):
        """The builder option ``key`` (``default`` when the table does not give it)."""
        return self.keywords.get(key, default)

    def with_options(self, **changes) -> ModelSpec:
        """The same builder with options changed."""
        return replace(self, keywords={**self.keywords, **changes})

    def table(self) -> dict:
        """The [model] table: ``builder``, its options, and ``merge`` when zones are merged."""
        out = {"builder": self.builder, **self.keywords}
        return {**out, "merge": dict(self.merge)} if self.merge else out


@dataclass(frozen=True)
class DataSpec(_Table):
    """The [data] table: measurement files and how to read them, what is observed, the noise."""

    file: Any = None
    #: None: not given (check-data reads files without it)
    observables: tuple | None = None
    stages: tuple | None = None
    noise: dict = field(default_factory=dict)
    regions: dict = field(default_factory=dict)
    format: str | None = None
    columns: Any = None
    strain: str | None = None
    forces: Any = None
    transform: Any = None
    relative_to: str | None = None
    strain_window: float | None = None
    strain_window_shape: str | None = None
    reactions: dict = field(default_factory=dict)
    plane_tolerance: float | None = None
    coordinates: str | None = None

    def __post_init__(self):
        super().__post_init__()
        for key in ("observables", "stages"):
            if getattr(self, key) is not None:
                object.__setattr__(self, key, tuple(getattr(self, key)))

    def table(self) -> dict:
        out = super().table()
        return {**out, **{key: list(getattr(self, key)) for key in ("observables", "stages")
                          if getattr(self, key) is not None}}


@dataclass(frozen=True)
class CalculixOptions(_Table):
    """The [solver] keys of the CalculiX backend
    (:class:`~frictionid.backends.calculix.backend.CalculixSettings` documents them)."""

    ccx: str = "ccx"
    timeout: float = 3600.0
    keep_work: bool = False
    work_dir: str | None = None
    threads: int = 1
    contact: str = "surface-to-surface"
    normal_stiffness: float | None = None
    stick_slope: float | None = None
    load_scale: float = 1.0


@dataclass(frozen=True, kw_only=True)
class SolverOptions(CalculixOptions):
    """The [solver] table: the backend, the CalculiX backend's keys and the embedded solver's (``work_dir``
    absolute). Keyword arguments only (the CalculiX keys come first in the fields)."""

    backend: str = "embedded"
    factorisation: str = "auto"
    increments: str = "fixed"
    sliding: str = "small"
    #: the small-sliding check's tolerance (:meth:`frictionid.fem.problem.Problem.check_small_sliding`); false: off
    slip_tolerance: float | bool = 0.1
    max_memory: float | None = None


@dataclass(frozen=True)
class IdentifyOptions(_Table):
    """The [identify] table: the method, the Jacobian, the objective and what is done around the fit."""

    method: str = "trf"
    jacobian: str = "analytic"
    max_iterations: int = 50
    tol: float = 1e-10
    step: float = 1e-4
    power: float = 2.0
    tikhonov: float = 0.0
    prior: Any = None
    penalty: float = 0.0
    #: the method's own keyword options (checked by :func:`frictionid.inverse.optimisers.check_method`)
    options: dict = field(default_factory=dict)
    resolution: float = 0.02
    suggestions: int = 5
    loss: str = "linear"
    loss_scale: float = 3.0
    model_error: str = "auto"
    refine_target: float = 0.5
    refine_budget: int = 2
    starts: Any = 1
    seed: int = 0
    profile: Any = False
    profile_points: int = 11

    @property
    def method_options(self) -> dict:
        """The method's keyword options, as a dict of its own."""
        return dict(self.options)


@dataclass(frozen=True)
class RunOptions(_Table):
    """The [run] table: the run's folder and where its solves run."""

    dir: str | None = None
    workers: int = 1
    scheduler: str | None = None
    retries: int = 2
    fields: bool = True


@dataclass(frozen=True)
class DesignOptions(_Table):
    """The [design] table: the choice of measurement points (``frictionid design``)."""

    points: int = 10
    candidates: str | None = None
    n_candidates: int = 400
    regions: Any = None
    criterion: str = "A"
    tolerance: float | None = None


#: the option object of each table config.py makes (the [friction] table becomes Parameters)
OPTION_TYPES = {"model": ModelSpec, "data": DataSpec, "solver": SolverOptions, "identify": IdentifyOptions,
                "run": RunOptions, "design": DesignOptions}
__all__ = ["DEFAULT_BOUNDS", "DataSpec", "DesignOptions", "IdentifyOptions", "ModelSpec", "RunOptions",
           "SolverOptions"]


def defaults(kind) -> dict:
    """The default of each key of an option object's table (config.py's schema)."""
    out = {}
    for f in fields(kind):
        value = f.default_factory() if f.default is MISSING else f.default
        out[f.name] = value
    return out
