"""The region each measurement point is read from, by the rules of a ``[data] regions`` table (point labels and
glob patterns, the most specific first)."""

from __future__ import annotations

import difflib
import fnmatch
import re

from ..errors import InputError


def _is_pattern(key: str) -> bool:
    return any(c in key for c in "*?[")


def _specificity(pattern: str) -> int:
    """Literal characters of a glob pattern (those outside ``*``, ``?`` and ``[...]``): "*" has 0."""
    return sum(1 for _ in _literal_parts(pattern))


def _literal_parts(pattern: str):
    """The literal characters of a glob pattern, one by one."""
    i = 0
    while i < len(pattern):
        if pattern[i] == "[" and "]" in pattern[i + 2:]:
            i = pattern.index("]", i + 2) + 1
        elif pattern[i] in "*?":
            i += 1
        else:
            yield pattern[i]
            i += 1


def region_of_points(regions: dict | None, labels, region_names, where: str = "data.regions") -> dict:
    """The region each point label is read from, by the rules of a ``[data] regions`` table.

    A key is a point label or a glob pattern (:func:`fnmatch.fnmatchcase`: ``*``, ``?``, ``[...]``). A label
    takes the value of its exact key; else of the matching pattern with the most literal characters (so
    ``"*"`` comes last); two matching patterns equally specific with different regions are an error. Labels
    no key matches get None (any cell).

    Parameters
    ----------
    regions : mapping key -> region name
    labels : every point label of the data
    region_names : the model's regions
    where : how messages name the table

    Raises
    ------
    InputError
        A key that matches no label (naming labels that exist), a value that is not one of the model's regions
        (with a "did you mean"), or a label two patterns claim equally.

    >>> region_of_points({"B*": "block", "B7": "base", "*": "base"}, ["B1", "B7", "P1"], ["block", "base"])
    {'B1': 'block', 'B7': 'base', 'P1': 'base'}
    """
    regions, labels = dict(regions or {}), list(dict.fromkeys(labels))
    matches = {key: [] for key in regions if _is_pattern(key)}        # labels of each pattern, one match per pattern
    for key in matches:
        match = re.compile(fnmatch.translate(key)).match
        matches[key] = list(labels) if key == "*" else [label for label in labels if match(label)]   # "*": all
    known = set(labels)
    for key, value in regions.items():
        if not isinstance(value, str) or value not in region_names:
            close = difflib.get_close_matches(str(value), list(region_names), n=1)
            hint = f" (did you mean {close[0]!r}?)" if close else ""
            raise InputError(f"{where}.{key}: {value!r} is not a region of the model{hint}; the model has "
                             f"{list(region_names)}")
        if key not in known and not matches.get(key):
            shown = ", ".join(labels[:5]) + (f", ... ({len(labels)} points)" if len(labels) > 5 else "")
            raise InputError(f"{where}: key {key!r} matches no point of the data (points: {shown}); a key is a "
                             "point label or a pattern such as \"B*\"")
    return _regions_of(labels, regions, matches, where)


def _regions_of(labels: list, regions: dict, matches: dict, where: str) -> dict:
    """Each label's region: its exact key, else its most specific matching pattern (ties with different regions
    are an error naming the first such label), else None."""
    found = {label: regions[label] for label in labels if label in regions}
    levels: dict = {}                                          # specificity -> patterns, in the table's order
    for key in matches:
        levels.setdefault(_specificity(key), []).append(key)
    tied: dict = {}                                            # label -> the equally specific patterns claiming it
    for level in sorted(levels, reverse=True):
        if len(levels[level]) == 1:                            # one pattern (e.g. "*"): no tie possible
            key = levels[level][0]
            found.update(dict.fromkeys([label for label in matches[key] if label not in found], regions[key]))
            continue
        claims: dict = {}
        for key in levels[level]:
            for label in matches[key]:
                if label not in found:
                    claims.setdefault(label, []).append(key)
        for label, keys in claims.items():
            if len({regions[k] for k in keys}) > 1:
                tied[label] = keys
            found[label] = regions[keys[0]]
    if tied:
        label = next(label for label in labels if label in tied)
        raise InputError(f"{where}: point {label!r} matches the patterns {tied[label]}, equally specific, with "
                         "different regions; name the point itself or make one pattern longer")
    regions_of = dict.fromkeys(labels)                      # None (any cell) unless a key gave one
    regions_of.update(found)
    return regions_of
