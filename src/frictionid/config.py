"""Config: the TOML file of an identification or simulation, validated key by key (DESIGN.md)."""

from __future__ import annotations

import difflib
import logging
import re
import tomllib
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path

import tomli_w

from .data.table import CHANNELS, QUANTITIES
from .errors import InputError
from .options import (DEFAULT_BOUNDS, DataSpec, DesignOptions, IdentifyOptions, ModelSpec, RunOptions,
                      SolverOptions, defaults)

log = logging.getLogger(__name__)

REQUIRED = object()   # marks a key without a default

def _schema(kind, required: tuple[str, ...] = ()) -> dict:
    return {**defaults(kind), **{key: REQUIRED for key in required}}


#: allowed keys per table, with their defaults (the option objects' own, frictionid.options)
SCHEMA = {
    "model": {"builder": REQUIRED},                  # builder options are checked against the builder
    "friction": {"zones": REQUIRED, "bounds": list(DEFAULT_BOUNDS), "fixed": {}, "merge": {}},
    "data": _schema(DataSpec, ("file", "observables", "stages")),
    "solver": _schema(SolverOptions),
    "identify": _schema(IdentifyOptions),
    "run": _schema(RunOptions, ("dir",)),
    "design": _schema(DesignOptions),
}
OPEN_TABLES = {"model"}
#: a message about a config key: it starts with a table's name ("data.noise.u: ...", "[friction] zones: ...")
_KEY_LED = re.compile(r"\[?(" + "|".join(SCHEMA) + r")\b")

#: expected type of each value (key -> (types, what to say)); checked before anything is built
TYPES = {
    "friction.zones": (dict, "a table of zone = start value"),
    "friction.fixed": (dict, "a table of zone = value"),
    "friction.merge": (dict, 'a table of merged zone = [zones], e.g. { AD = ["A", "D"] }'),
    "friction.bounds": ((list, dict), "a pair [lower, upper] or a table zone = [lower, upper] (\"*\": the others)"),
    "data.file": ((str, list, dict), 'a file name, a list of files (one per stage or view) or tables '
                                     '{ path = "...", stage = 2, view = "front", transform = {...} }'),
    "data.format": (str, 'an export format, e.g. "vic3d" (docs/data.md)'),
    "data.columns": (dict, 'a table of quantity = column name, e.g. { x = "X [mm]", ux = "U [mm]" }'),
    "data.strain": (str, '"engineering", "green-lagrange" or "log"'),
    "data.forces": (list, "a list of machine forces [N], one per stage"),
    "data.observables": (list, 'a list of quantity names, e.g. ["ux", "uy"]'),
    "data.transform": (dict, 'a table { rotation_deg = [rx, ry, rz], translation = [tx, ty, tz] } or '
                             '{ fit = "points", points = { ... } } (docs/data.md, "Frames")'),
    "data.relative_to": (str, 'a point label of the data file, e.g. "12"'),
    "data.strain_window": ((int, float), "a positive length [mm]: the DIC strain window, e.g. 0.8"),
    "data.strain_window_shape": (str, '"square" (default) or "circle" (of diameter strain_window)'),
    "data.coordinates": (str, '"reference" or "deformed": what the exports\' coordinate columns hold'),
    "data.plane_tolerance": ((int, float), "a length >= 0 [mm]: out-of-plane scatter projected onto a plane model's "
                                           "plane, e.g. 0.005"),
    "data.stages": (list, "a list of stage numbers, e.g. [2]"),
    "data.noise": (dict, "a table of standard deviations, e.g. { u = 0.0005 }"),
    "data.regions": (dict, 'a table of point = region, e.g. { "*" = "block" }'),
    "data.reactions": (dict, 'a table of observable = model reaction, e.g. { clamp = "plate1_rim.y" }'),
    "solver.backend": (str, "a backend name"),
    "solver.ccx": (str, "the name or path of the ccx executable"),
    "solver.timeout": ((int, float), "a number of seconds"),
    "solver.work_dir": (str, "a folder name"),
    "solver.keep_work": (bool, "true or false (keep every ccx work folder)"),
    "solver.threads": (int, "a whole number"),
    "solver.contact": (str, '"surface-to-surface" or "node-to-surface"'),
    "solver.normal_stiffness": ((int, float), "a number [N/mm^3]"),
    "solver.stick_slope": ((int, float), "a number [N/mm^3]"),
    "solver.load_scale": ((int, float), "a number > 0"),
    "solver.factorisation": (str, '"auto", "cholmod", "superlu" or "mumps"'),
    "solver.increments": (str, '"fixed" or "adaptive"'),
    "solver.sliding": (str, '"small" or "finite"'),
    "solver.slip_tolerance": ((int, float, bool), "a number > 0 (the small-sliding check's tolerance) or false "
                                                  "(no check)"),
    "solver.max_memory": ((int, float), "a memory size [GB] > 0"),
    "identify.method": (str, "a method name"),
    "identify.jacobian": (str, '"analytic", "forward" or "central"'),
    "identify.max_iterations": (int, "a whole number"),
    "identify.tol": ((int, float), "a number"),
    "identify.step": ((int, float), "a number"),
    "identify.power": ((int, float), "a number"),
    "identify.tikhonov": ((int, float), "a number"),
    "identify.penalty": ((int, float), "a number"),
    "identify.options": (dict, "a table"),
    "identify.resolution": ((int, float), "a positive number (largest predicted standard error of a resolved zone)"),
    "identify.suggestions": (int, "a whole number (0: propose no extra observations)"),
    "identify.loss": (str, '"linear" or a robust loss: "soft_l1", "huber", "cauchy", "arctan"'),
    "identify.loss_scale": ((int, float), "a positive number (residual, in units of the stated noise, beyond "
                                          "which a robust loss down-weights an observation)"),
    "identify.model_error": (str, '"auto", "off", "estimate" or "include"'),
    "identify.refine_target": ((int, float), "a number >= 0 (largest RMS model error per quantity kind in "
                                             "noise levels; 0: no discretisation control)"),
    "identify.refine_budget": (int, "a whole number >= 1 (refinement factors up to 2^budget)"),
    "identify.starts": ((int, list), "a number of starts or a list of start points (each a list of values or "
                                     "a table zone = value)"),
    "identify.seed": (int, "a whole number (seed of the drawn start points)"),
    "identify.profile": ((bool, list), 'true (every free zone) or a list of zones, e.g. ["A", "B"]'),
    "identify.profile_points": (int, "a whole number >= 3 (held values per profile)"),
    "run.dir": (str, "a folder name"),
    "run.workers": (int, "a whole number"),
    "run.scheduler": (str, '"local" or the address of a Dask scheduler, "tcp://host:port"'),
    "run.retries": (int, "a whole number >= 0 (runs of a task lost with its worker, or failed, after the first)"),
    "run.fields": (bool, "true or false"),
    "design.points": (int, "a whole number of points to choose"),
    "design.candidates": (str, '"surface" or "section"'),
    "design.n_candidates": (int, "a whole number of candidate points"),
    "design.regions": (list, 'a list of region names, e.g. ["bolt", "nut"]'),
    "design.criterion": (str, '"A" (sum of variances) or "D" (determinant)'),
    "design.tolerance": ((int, float), "a positive number (largest predicted standard error of a resolved zone)"),
}


def _check_types(tables: dict, path: Path) -> None:
    for dotted, (types, what) in TYPES.items():
        table, key = dotted.split(".")
        value = tables[table].get(key)
        if value is None:
            continue
        # a bool is an int to Python: only a key typed bool (alone or among others) takes one
        takes_bool = bool in (types if isinstance(types, tuple) else (types,))
        if isinstance(value, bool) and not takes_bool or not isinstance(value, types):
            raise InputError(f"{path}: {dotted} must be {what}, got {value!r}")
    for dotted, kind in (("data.observables", str), ("data.stages", int)):
        table, key = dotted.split(".")
        for item in tables[table].get(key) or []:
            if isinstance(item, bool) or not isinstance(item, kind):
                raise InputError(f"{path}: {dotted} has {item!r}; expected {TYPES[dotted][1]}")


#: the observables a [data] table can name: point quantities and the per-stage reaction sums
OBSERVABLES = QUANTITIES + ("force",) + tuple(CHANNELS)
#: keys of the tables inside tables (table.key -> allowed keys); the values are checked by :data:`ENTRY_CHECKS`
SUBKEYS = {"data.noise": ("u", "e") + OBSERVABLES, "data.reactions": tuple(CHANNELS)}


def _positive(value) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool) and value > 0 and value != float("inf")


#: what each entry of a table inside a table must be: (test, what to say)
ENTRY_CHECKS = {"data.noise": (_positive, "a positive number (a standard deviation in the quantity's unit: mm, "
                                          "strain, N, N m)"),
                 "data.reactions": (lambda value: isinstance(value, str) and bool(value),
                                    'a reaction label of the model, e.g. "plate1_rim.y"')}


def _check_subtables(tables: dict, path: Path) -> None:
    for dotted, known in SUBKEYS.items():
        table, key = dotted.split(".")
        for entry, value in (tables[table].get(key) or {}).items():
            if entry not in known:
                raise InputError(f"{path}: unknown key {dotted}.{entry}{_suggest(entry, known)}; known keys are "
                                 f"{list(known)}")
            test, what = ENTRY_CHECKS[dotted]
            if not test(value):
                raise InputError(f"{path}: {dotted}.{entry} must be {what}, got {value!r}")
    observed = tables["data"].get("observables") or []
    for name in observed:
        if name not in OBSERVABLES:
            raise InputError(f"{path}: data.observables has {name!r}{_suggest(name, OBSERVABLES)}; observables are "
                             f"{list(OBSERVABLES)}")
    kinds = set(observed) | {q[0] for q in observed if q in QUANTITIES}
    unused = [key for key in tables["data"].get("noise") or {} if observed and key not in kinds]
    if unused:                  # legal, but likely a slip: the noise meant for an observable is not where it acts
        log.warning("%s: data.noise gives %s, but no observed quantity (data.observables = %s) uses %s", path,
                    ", ".join(unused), observed, "it" if len(unused) == 1 else "them")


#: allowed values of string keys that take one of a few names (keys checked elsewhere are not listed)
CHOICES = {"solver.contact": ("surface-to-surface", "node-to-surface"),
           "solver.factorisation": ("auto", "cholmod", "superlu", "mumps"), "solver.increments": ("fixed", "adaptive"),
           "solver.sliding": ("small", "finite"), "identify.model_error": ("auto", "off", "estimate", "include")}


#: lowest value of numeric keys, and whether the bound itself is allowed (the keys' meaning is in TYPES)
RANGES = {"solver.timeout": (0, False), "solver.threads": (1, True), "solver.load_scale": (0, False),
          "solver.normal_stiffness": (0, False), "solver.stick_slope": (0, False),
          "identify.max_iterations": (0, True), "identify.step": (0, False), "identify.resolution": (0, False),
          "identify.suggestions": (0, True), "identify.loss_scale": (0, False), "identify.tikhonov": (0, True),
          "identify.penalty": (0, True), "identify.refine_target": (0, True), "identify.refine_budget": (1, True),
          "identify.profile_points": (3, True), "run.workers": (1, True), "run.retries": (0, True),
          "design.points": (1, True), "design.n_candidates": (1, True), "design.tolerance": (0, False),
          "data.strain_window": (0, False)}


def _check_ranges(tables: dict, path: Path) -> None:
    tolerance = tables["solver"].get("slip_tolerance")
    if tolerance is True or tolerance is not None and tolerance is not False and not tolerance > 0:
        raise InputError(f"{path}: solver.slip_tolerance must be a number > 0 or false, got {tolerance!r} (expected "
                         f"{TYPES['solver.slip_tolerance'][1]})")
    for dotted, (low, inclusive) in RANGES.items():
        table, key = dotted.split(".")
        value = tables[table].get(key)
        if value is not None and not (value >= low if inclusive else value > low):
            raise InputError(f"{path}: {dotted} must be {'>=' if inclusive else '>'} {low}, got {value!r} "
                             f"(expected {TYPES[dotted][1]})")


def _check_choices(tables: dict, path: Path) -> None:
    for dotted, names in CHOICES.items():
        table, key = dotted.split(".")
        value = tables[table].get(key)
        if value is not None and value not in names:
            raise InputError(f"{path}: {dotted} must be {TYPES[dotted][1]}, got {value!r}"
                             f"{_suggest(value, names)}")


@dataclass(frozen=True)
class Config:
    """A validated configuration: each table made once into its frozen option object (frictionid.options);
    ``friction`` stays a table until the model's zones make it Parameters; paths are absolute."""

    path: Path
    text: str
    model: ModelSpec
    friction: dict
    data: DataSpec
    solver: SolverOptions
    identify: IdentifyOptions
    run: RunOptions
    design: DesignOptions
    name: str | None = None

    @property
    def model_spec(self) -> ModelSpec:
        """The [model] the model is built from: with ``[friction] merge`` given, carrying it (so that a refined
        model merges alike, :func:`frictionid.builders.registry.build_model`)."""
        merge = self.friction.get("merge")
        return ModelSpec(self.model.builder, self.model.keywords, merge) if merge else self.model

    @property
    def where(self) -> str:
        """How messages name the config: its file, or the name given to :func:`config_from_dict`."""
        return self.name if self.name is not None else str(self.path)

    @contextmanager
    def naming_keys(self):
        """Checks made later (against the model, the data) raise messages that start with the config key they
        are about ("data.stages: ..."); inside this block those get the config's file in front, as config.py's
        own messages have."""
        try:
            yield
        except InputError as exc:
            message = str(exc)
            if not _KEY_LED.match(message):
                raise
            raise InputError(f"{self.where}: {message}") from None

    def resolve(self, value: str) -> Path:
        """A path from the config, relative to the config file's folder."""
        path = Path(value)
        return path if path.is_absolute() else (self.path.parent / path).resolve()


def _suggest(key: str, known) -> str:
    """" (did you mean 'x'?)" for the known name closest to ``key``, or the one it abbreviates ("f": "force")."""
    close = difflib.get_close_matches(key, list(known), n=1) or [k for k in known if k.startswith(key)][:1]
    return f" (did you mean {close[0]!r}?)" if close else ""


def _table(raw: dict, name: str, path: Path) -> dict:
    value = raw.get(name, {})
    if not isinstance(value, dict):
        raise InputError(f"{path}: [{name}] must be a table")
    schema = SCHEMA[name]
    if name not in OPEN_TABLES:
        for key in value:
            if key not in schema:
                raise InputError(f"{path}: unknown key {name}.{key}{_suggest(key, schema)}; "
                                 f"known keys are {sorted(schema)}")
    return {**{k: v for k, v in schema.items() if v is not REQUIRED}, **value}


def read_config(path: str | Path, need: tuple[str, ...] = ("model", "friction")) -> Config:
    """Read and validate a config file; ``need`` lists the tables that must be present."""
    path = Path(path)
    try:
        text = path.read_text()
    except OSError as exc:
        raise InputError(f"{path}: cannot read the config ({exc.strerror})") from None
    try:
        raw = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise InputError(f"{path}: not valid TOML: {exc}") from None
    return _validated(raw, path.resolve(), text, need)


def config_from_dict(tables: dict, need: tuple[str, ...] = ("model", "friction"), base: str | Path = ".",
                     name: str = "config") -> Config:
    """A :class:`Config` from tables as a TOML file would give them (``{"model": {...}, "friction": {...}}``),
    validated the same way; relative paths resolve against ``base``, messages start with ``name``.

    >>> config = config_from_dict({"model": {"builder": "block2d"}, "friction": {"zones": {"A": 0.1, "B": 0.1}}})
    >>> config.identify.method, config.friction["bounds"]
    ('trf', [0.0, 1.0])
    """
    if not isinstance(tables, dict):
        raise InputError(f"{name}: expected a table of tables, got {type(tables).__name__}")
    tables = {key: value for key, value in tables.items() if value is not None}
    try:
        text = tomli_w.dumps(_without_none(tables))
    except (TypeError, ValueError) as exc:
        raise InputError(f"{name}: cannot be written as TOML: {exc}") from None
    return _validated(tables, Path(base).resolve() / name, text, need, name)


def _without_none(value):
    """TOML has no null: keys whose value is None (a default) are left out of the text."""
    if isinstance(value, dict):
        return {k: _without_none(v) for k, v in value.items() if v is not None}
    if isinstance(value, (list, tuple)):
        return [_without_none(v) for v in value]
    return value


def _validated(raw: dict, path: Path, text: str, need: tuple[str, ...], name: str | None = None) -> Config:
    where = Path(name) if name is not None else path
    for table in raw:
        if table not in SCHEMA:
            raise InputError(f"{where}: unknown table [{table}]{_suggest(table, SCHEMA)}; "
                             f"known tables are {sorted(SCHEMA)}")
    for table in need:
        if table not in raw:
            raise InputError(f"{where}: missing table [{table}]")
    tables = {table: _table(raw, table, where) for table in SCHEMA}
    _check_types(tables, where)
    _check_choices(tables, where)
    _check_ranges(tables, where)
    _check_subtables(tables, where)
    if isinstance(tables["model"].get("file"), str):      # a builder's mesh file: relative to the config's folder
        tables["model"]["file"] = str(path.resolve().parent / tables["model"]["file"])
    for table, key in (("model", "builder"), ("friction", "zones")):
        if table in need and key not in tables[table]:
            raise InputError(f"{where}: missing key {table}.{key}")
    for key in ("file", "observables", "stages"):
        if "data" in need and key not in tables["data"]:
            raise InputError(f"{where}: missing key data.{key}")
    if "run" in need and "dir" not in tables["run"]:
        raise InputError(f"{where}: missing key run.dir")
    if tables["solver"].get("work_dir"):                   # ccx's work folders: relative to the config's folder
        tables["solver"]["work_dir"] = str((path.parent / tables["solver"]["work_dir"]).resolve())
    return Config(path=path, text=text, model=ModelSpec.from_table(tables["model"]), friction=tables["friction"],
                  data=DataSpec.from_table(tables["data"]), solver=SolverOptions.from_table(tables["solver"]),
                  identify=IdentifyOptions.from_table(tables["identify"]), run=RunOptions.from_table(tables["run"]),
                  design=DesignOptions.from_table(tables["design"]), name=name)
