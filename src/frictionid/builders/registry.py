"""Model builders by name, with their options checked against the builder's signature."""

from __future__ import annotations

import difflib
import inspect

from ..errors import InputError
from ..model import Model
from .block import block_model, block_model_2d
from .bolt import bolt_model

BUILDERS = {"block": block_model, "block2d": block_model_2d, "bolt": bolt_model}


def build_model(options: dict, where: str = "[model]") -> Model:
    """The model a [model] table describes: ``builder`` plus that builder's keyword options."""
    options = dict(options)
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
