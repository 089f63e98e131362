"""Below config.py no layer takes a config table: the signatures of every public function, class and method of
frictionid.backends, .builders, .data and .inverse are walked, and each parameter is held to three rules.

1. A parameter named after a config table (``config``, ``friction``, ``model_options``, ``model_spec``, ``data``,
   ``solver``, ``identify``, ``ident``, ``run``, ``design``) is annotated with that table's option object
   (frictionid.options; ``config`` and ``friction``: never, a Config stays above and [friction] becomes
   Parameters).
   :data:`SAME_NAME` lists the parameters that share a table's name but are something else.
2. No parameter is annotated ``Mapping``.
3. A parameter annotated with ``dict`` (also inside, e.g. ``tuple[dict, ...]``), and one named ``table``,
   ``tables`` or ``options`` without another annotation, is listed in :data:`DICTS` with what it holds: per-name
   values (by point, quantity, zone, ...), records being written, or the value of one key that its owner alone
   parses (a builder option, a transform, the method's options). A new one fails until it is listed or typed.
"""

import importlib
import inspect
import pkgutil
import re

import pytest

from frictionid import options

LAYERS = ("backends", "builders", "data", "inverse")
#: the option object a parameter of a table's name must be annotated with (None: no parameter of that name)
TABLE_NAMES = {"config": None, "friction": None, "model_options": "ModelSpec",
               "model_spec": "ModelSpec", "data": "DataSpec", "solver": "SolverOptions",
               "identify": "IdentifyOptions", "ident": "IdentifyOptions", "run": "RunOptions",
               "design": "DesignOptions"}
#: parameters named like a table that are not one
SAME_NAME = {"inverse.gradient_descent:gradient_descent.run": "the Iterates of this optimisation"}
TABLE_LIKE = ("table", "tables", "options")

PER_NAME = "values per name (point, quantity, zone, set, column), not options"
RECORD = "a record being written (result.json, the store), not options"
ONE_KEY = "the value of one key, parsed by its one owner into a typed object"
DICTS = {
    "backends.calculix.parse:DatFile.nodal": PER_NAME, "backends.calculix.parse:DatFile.totals": PER_NAME,
    "backends.calculix.parse:DatFile.contact": PER_NAME,
    "builders.arguments:checked_table.table": ONE_KEY + " (a builder option's table)",
    "builders.arguments:checked_table.allowed": PER_NAME,
    "builders.bolt3d_mesh:separate_bodies.owner": PER_NAME, "builders.bolt3d_mesh:classify_faces.volumes": PER_NAME,
    "builders.mesh:MeshFile.regions": PER_NAME, "builders.mesh:MeshFile.boundaries": PER_NAME,
    "builders.mesh:MeshFile.node_sets": PER_NAME,
    "builders.mesh_inp:InpSets.elsets": PER_NAME, "builders.mesh_inp:InpSets.nsets": PER_NAME,
    "builders.mesh_inp:InpSets.surfaces": PER_NAME,
    "builders.subdivide:subdivide.facets": PER_NAME, "builders.subdivide:subdivide.node_sets": PER_NAME,
    "builders.zone_rules:Box.from_table.table": ONE_KEY + " (a zone rule of the mesh builder's zones)",
    "builders.zone_rules:HalfSpace.from_table.table": ONE_KEY, "builders.zone_rules:Ring.from_table.table": ONE_KEY,
    "builders.zone_rules:Axial.from_table.table": ONE_KEY, "builders.zone_rules:Sector.from_table.table": ONE_KEY,
    "builders.zone_rules:zone_rule.table": ONE_KEY, "builders.zone_rules:zone_rules.tables": ONE_KEY,
    "data.dic.layout:Layout.columns": PER_NAME, "data.dic.layout:Layout.units": PER_NAME,
    "data.dic.layout:Layout.column_units": PER_NAME, "data.dic.layout:ExportReport.columns": PER_NAME,
    "data.dic.layout:ExportReport.units": PER_NAME, "data.dic.layout:ExportReport.dropped": PER_NAME,
    "data.dic.registry:choose_layout.columns": ONE_KEY + " (data.columns)",
    "data.dic.registry:read_export.columns": ONE_KEY + " (data.columns)",
    "data.dic.window:WindowChoice.files": RECORD,
    "data.frames:FrameSpec.points": PER_NAME, "data.frames:frame_spec.table": ONE_KEY + " (data.transform)",
    "data.frames:rotated_columns.columns": PER_NAME,
    "data.sources:Entry.columns": ONE_KEY + " (data.columns)",
    "data.sources:Sources.frames": RECORD, "data.sources:Sources.relative": PER_NAME,
    "data.sources:Sources.specimens": PER_NAME, "data.sources:Sources.files": RECORD,
    "data.table:Measurements.values": PER_NAME, "data.table:Measurements.sigma": PER_NAME,
    "data.table:Measurements.channels": PER_NAME,
    "inverse.discretisation_refit:StoredEstimate.put.step": RECORD + " (a direction's record, stored)",
    "inverse.discretisation_refit:PhaseStore.record.outputs": RECORD,
    "inverse.discretisation_refit:Decision.record": RECORD + " (model.discretisation.at_fitted)",
    "inverse.model_error:ModelError.scales": PER_NAME + " (the estimate's scale per quantity)",
    "inverse.adequacy:Adequacy.by_quantity": RECORD, "inverse.adequacy:Adequacy.by_stage": RECORD,
    "inverse.adequacy:Adequacy.by_group": RECORD, "inverse.adequacy:kinds_beyond_noise.by_quantity": RECORD,
    "inverse.adequacy:point_group.regions": PER_NAME + " (data.regions: point pattern -> region)",
    "inverse.adequacy:assess.regions": PER_NAME + " (data.regions)",
    "inverse.discretisation_control:Control.record": RECORD,
    "inverse.discretisation:used_mode.record": RECORD + " (model.discretisation, read for the reason)",
    "inverse.gradient_descent:gradient_descent.options": ONE_KEY + " (identify.options, resolved by iterates)",
    "inverse.iterates:Iterates.result.options": RECORD, "inverse.iterates:resolve_options.spec": PER_NAME,
    "inverse.iterates:resolve_options.given": ONE_KEY + " (identify.options)",
    "inverse.least_squares:OptimiseResult.options": RECORD,
    "inverse.mistakes:scale_hints.shares": PER_NAME, "inverse.mistakes:noise_hint.rms": PER_NAME,
    "inverse.model_error:ModelError.orders": PER_NAME, "inverse.model_error:estimate_model_error.orders": PER_NAME,
    "inverse.remaining_error:RemainingError.orders": PER_NAME, "inverse.remaining_error:remaining.kind_orders": PER_NAME,
    "inverse.reactions:check_reaction_keys.reactions": PER_NAME + " (data.reactions)",
    "inverse.reactions:channel_reaction.reactions": PER_NAME + " (data.reactions)",
    "inverse.point_regions:region_of_points.regions": PER_NAME + " (data.regions)",
    "inverse.observations:noise_of.noise": PER_NAME + " (data.noise)",
    "inverse.observations:observations_from.relative": PER_NAME + " (read from the files)",
    "inverse.observations:observations_from.specimens": PER_NAME + " (read from the files)",
    "inverse.optimisers:optimise.options": ONE_KEY + " (identify.options)",
    "inverse.optimisers:check_method.options": ONE_KEY + " (identify.options)",
    "inverse.parameters:Parameters.from_dict.zones": PER_NAME,
    "inverse.parameters:Parameters.from_dict.fixed": PER_NAME,
    "inverse.parameters:Parameters.from_config.zones": ONE_KEY + " (friction.zones, made Parameters here)",
    "inverse.parameters:Parameters.from_config.fixed": ONE_KEY + " (friction.fixed)",
    "inverse.profile:HeldStore.record.outputs": RECORD,
    "inverse.refits:HeldRefits.profiles.result": RECORD, "inverse.refits:HeldRefits.check_bounds.result": RECORD,
    "inverse.shift:CoefficientShift.noise": PER_NAME + " (data.noise)",
    "inverse.shift:coefficient_shift.noise": PER_NAME + " (data.noise)",
}


def _callables(module):
    """(qualified name, function) of a module's public functions, classes (their signature) and methods."""
    for name, obj in vars(module).items():
        if name.startswith("_") or getattr(obj, "__module__", None) != module.__name__:
            continue
        if inspect.isfunction(obj):
            yield name, obj
        elif inspect.isclass(obj):
            yield name, obj
            for member, value in vars(obj).items():
                function = getattr(value, "__func__", value)
                if not member.startswith("_") and inspect.isfunction(function):
                    yield f"{name}.{member}", function


def _parameters():
    """(key "layer.module:Qualname.parameter", parameter name, annotation text) below config.py."""
    for layer in LAYERS:
        package = importlib.import_module(f"frictionid.{layer}")
        for info in pkgutil.walk_packages(package.__path__, package.__name__ + "."):
            module = importlib.import_module(info.name)
            for qualname, function in _callables(module):
                try:
                    signature = inspect.signature(function)
                except (TypeError, ValueError):
                    continue
                for parameter in signature.parameters.values():
                    annotation = parameter.annotation
                    text = "" if annotation is inspect.Parameter.empty else \
                        annotation if isinstance(annotation, str) else getattr(annotation, "__name__", str(annotation))
                    key = f"{info.name.removeprefix('frictionid.')}:{qualname}.{parameter.name}"
                    yield key, parameter.name, text


def violations(parameters) -> list[str]:
    """What breaks the module docstring's rules among (key, name, annotation) triples."""
    found = []
    for key, name, text in parameters:
        if name in ("self", "cls"):
            continue
        if name in TABLE_NAMES and key not in SAME_NAME:
            expected = TABLE_NAMES[name]
            if expected is None or not re.search(rf"\b{expected}\b", text):
                found.append(f"{key}: named after a config table, annotated {text or 'nothing'}; expected "
                             f"{expected or 'no such parameter'}")
        if re.search(r"\b(Mapping|MutableMapping)\b", text):
            found.append(f"{key}: annotated {text}")
        elif (re.search(r"\bdict\b", text) or name in TABLE_LIKE and not text) and key not in DICTS:
            found.append(f"{key}: a dict ({text or 'not annotated'}) not listed in DICTS")
    return found


def test_no_layer_below_config_takes_a_config_table():
    found = violations(list(_parameters()))
    assert not found, "\n".join(found)


def test_every_listed_dict_still_exists():
    """The list stays the list of what is there: an entry whose parameter went is removed with it."""
    keys = {key for key, _, _ in _parameters()}
    assert not [key for key in (*DICTS, *SAME_NAME) if key not in keys]


@pytest.mark.parametrize("triple, expected", [
    (("inverse.x:f.solver", "solver", "dict"), "named after a config table"),
    (("inverse.x:f.solver", "solver", ""), "named after a config table"),
    (("inverse.x:f.config", "config", "Config"), "named after a config table"),
    (("data.x:f.noise", "noise", "Mapping[str, float]"), "annotated Mapping"),
    (("data.x:f.noise", "noise", "dict | None"), "not listed in DICTS"),
    (("builders.x:f.options", "options", ""), "not listed in DICTS"),
])
def test_the_rules_see_a_table_passed_down(triple, expected):
    assert expected in "\n".join(violations([triple]))


@pytest.mark.parametrize("triple", [("inverse.x:f.solver", "solver", "SolverOptions"),
                                    ("inverse.x:f.model_options", "model_options", "ModelSpec | None"),
                                    ("data.x:f.noise", "noise", "float"),
                                    ("inverse.gradient_descent:gradient_descent.run", "run", "Iterates"),
                                    ("inverse.optimisers:optimise.options", "options", "dict | None")])
def test_the_rules_pass_typed_options_and_listed_dicts(triple):
    assert violations([triple]) == []


def test_each_table_has_its_frozen_option_object():
    from dataclasses import FrozenInstanceError

    from frictionid.config import config_from_dict

    config = config_from_dict({"model": {"builder": "block2d"}, "friction": {"zones": {"A": 0.1}}})
    for table, kind in options.OPTION_TYPES.items():
        assert type(getattr(config, table)) is kind, table
    with pytest.raises(FrozenInstanceError):
        config.identify.jacobian = "central"


def test_a_whole_number_given_for_a_float_key_is_a_float_in_the_options():
    """TOML writes "tol = 1" as an integer; the option objects hold the float every user of the key expects, so
    no layer casts it again."""
    from frictionid.config import config_from_dict

    config = config_from_dict({"model": {"builder": "block2d"}, "friction": {"zones": {"A": 0.1}},
                               "identify": {"tol": 1, "step": 1, "max_iterations": 3}, "solver": {"timeout": 60}})
    assert type(config.identify.tol) is float and type(config.identify.step) is float
    assert type(config.solver.timeout) is float and config.identify.max_iterations == 3
    assert type(config.identify.max_iterations) is int
