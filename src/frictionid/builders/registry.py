"""Model builders by name, with their options checked against the builder's signature."""

from __future__ import annotations

import difflib
import inspect
import os

from ..errors import InputError
from ..model import Model
from ..model.merge import merge_zones
from ..options import ModelSpec
from .block import block_model, block_model_2d
from .bolt import bolt_model, default_sizes
from .mesh import mesh_model, source_files

BUILDERS = {"block": block_model, "block2d": block_model_2d, "bolt": bolt_model, "mesh": mesh_model}
#: the element-size options [mm] :func:`refined` divides, per builder; block2d's ``contact_size`` left out
#: follows its ``mesh_size``; the 3-D bolt's ``root_size`` (and ``head_size`` where given) too, so that every
#: size of its mesh is halved
SIZE_OPTIONS = {"block": ("mesh_size",), "block2d": ("mesh_size", "contact_size"),
                "bolt": ("flank_size", "contact_size", "mesh_size", "root_size", "head_size")}
#: element-count options :func:`refined` multiplies, per builder
COUNT_OPTIONS = {"block": ("block_divisions",)}


#: models built recently, by their [model] table (models are immutable, so equal tables share one)
_BUILT: dict = {}
N_BUILT = 4


def build_model(spec: ModelSpec, where: str = "[model]") -> Model:
    """The model a [model] describes: ``builder`` called with its keyword options, and the zones of ``merge``
    made one (:func:`frictionid.model.merge.merge_zones`; an identification puts ``[friction] merge`` there, so
    that a refined model merges alike).

    The last :data:`N_BUILT` models are kept, so the runs of one session that describe the same model (a study's
    identifications, a replay) mesh it once. A table naming a mesh ``file`` is keyed by the size and modification
    time of the file and of every file it includes too (:func:`source_files`), so a mesh file or an included one
    written again builds a new model.
    """
    options = spec.table()
    key = repr(sorted(options.items()))
    if isinstance(options.get("file"), str) and os.path.isfile(options["file"]):
        for path in source_files(options["file"]):
            stat = path.stat()
            key += f" {path} {stat.st_size} {stat.st_mtime_ns}"
    if key in _BUILT:
        _BUILT[key] = _BUILT.pop(key)                          # most recently used last
        return _BUILT[key]
    model = _build(options, where)
    while len(_BUILT) >= N_BUILT:
        _BUILT.pop(next(iter(_BUILT)))
    _BUILT[key] = model
    return model


def _build(options: dict, where: str) -> Model:
    merge = options.pop("merge", None)
    model = _built(options, where)
    return merge_zones(model, merge, "friction.merge") if merge else model


def _built(options: dict, where: str) -> Model:
    name = options.pop("builder", None)
    if name not in BUILDERS:
        raise InputError(f"{where} builder = {name!r} is not one of {sorted(BUILDERS)}")
    builder = BUILDERS[name]
    known = inspect.signature(builder).parameters
    for key in options:
        if key not in known:
            close = difflib.get_close_matches(key, list(known), n=1)
            hint = f" (did you mean {close[0]!r}?)" if close else ""
            raise InputError(f"{where} {key}: not an option of builder {name!r}{hint}; options are {sorted(known)}")
    try:
        return builder(**options)
    except TypeError as exc:
        raise InputError(f"{where}: {exc}") from None
    except InputError as exc:           # the builder names the option; the config's file and table go first
        message = str(exc)
        raise InputError(message if message.startswith(where) else f"{where}: {message}") from None


def _refined_mesh(options: dict, factor: int, where: str) -> dict:
    """A user's mesh refined by ``factor`` (a power of 2): its ``refine`` raised by log2(factor).

    >>> _refined_mesh({"builder": "mesh", "file": "joint.msh"}, 4, "[model]")["refine"]
    2
    """
    steps = factor.bit_length() - 1
    if factor != 1 << steps:
        raise InputError(f"{where} builder = 'mesh' is refined by subdivision, halving its element sizes: the "
                         f"refinement factor must be a power of 2, got {factor}")
    refine = options.get("refine", 0)
    if isinstance(refine, bool) or not isinstance(refine, int) or refine < 0:
        raise InputError(f"{where} refine = {refine!r}: must be a whole number >= 0")
    return {**options, "refine": refine + steps}


def _default(name: str, options: dict, key: str):
    """The value builder ``name`` takes for ``key`` when ``options`` do not give it (None: decided later)."""
    value = inspect.signature(BUILDERS[name]).parameters[key].default
    if value is None and name == "bolt":
        signature = inspect.signature(bolt_model).parameters
        return default_sizes(options.get("size", signature["size"].default),
                             options.get("model", signature["model"].default)).get(key)
    return value


def _number(where: str, key: str, value):
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise InputError(f"{where} {key}: must be a number to be refined, got {value!r}")
    return value


def refined(spec: ModelSpec, factor: int = 2, where: str = "[model]") -> ModelSpec:
    """The [model] of the same builder with every element size divided by ``factor``.

    block: ``mesh_size`` / factor and ``block_divisions`` * factor (when given); block2d: ``mesh_size`` and
    ``contact_size`` / factor; bolt: ``flank_size``, ``contact_size`` and ``mesh_size`` (3-D also ``root_size`` and
    a given ``head_size``) / factor. A size the options leave out is taken from the builder's default (block2d's
    ``contact_size`` then stays out: it follows ``mesh_size``). Other options are unchanged.

    Raises
    ------
    InputError
        For ``factor`` not an integer >= 2, a size that is not a number, or a builder without size options.
        A user's mesh (builder "mesh") is refined by uniform subdivision: its ``refine`` option is raised by
        log2(factor), which must be a whole number.

    Examples
    --------
    >>> block = ModelSpec.from_table({"builder": "block", "mesh_size": 2.5, "block_divisions": 6, "order": 2})
    >>> refined(block).table()
    {'builder': 'block', 'mesh_size': 1.25, 'block_divisions': 12, 'order': 2}
    >>> refined(ModelSpec.from_table({"builder": "bolt", "flank_size": 0.2})).option("contact_size")
    0.25
    """
    if isinstance(factor, bool) or not isinstance(factor, int) or factor < 2:
        raise InputError(f"refinement `factor` must be an integer >= 2, got {factor!r}")
    name, options = spec.builder, spec.table()
    if name == "mesh":
        return ModelSpec.from_table(_refined_mesh(options, factor, where))
    if name not in SIZE_OPTIONS:
        raise InputError(f"{where} builder = {name!r}: the model cannot be refined automatically (only the "
                         f"builders {sorted(SIZE_OPTIONS)} have element-size options, and builder 'mesh' is "
                         "subdivided)")
    out = dict(options)
    for key in SIZE_OPTIONS[name]:
        value = options.get(key, _default(name, options, key))
        if value is not None:
            out[key] = _number(where, key, value) / factor
    for key in COUNT_OPTIONS.get(name, ()):
        if options.get(key) is not None:
            out[key] = _number(where, key, options[key]) * factor
    return ModelSpec.from_table(out)
