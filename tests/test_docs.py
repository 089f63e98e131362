"""The user documentation covers what the code reads, and cites only documents the repository has."""

import inspect
import re
from pathlib import Path

import pytest

from frictionid.builders.registry import BUILDERS
from frictionid.config import SCHEMA
from frictionid.inverse.gradient_descent import OPTIONS as GRADIENT_DESCENT_OPTIONS
from frictionid.inverse.optimisers import LBFGSB_OPTIONS, NELDER_MEAD_OPTIONS, TRF_OPTIONS

ROOT = Path(__file__).parents[1]
CONFIG_DOC = (ROOT / "docs" / "config.md").read_text()
DOCUMENTS = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]


def _section(text: str, heading: str) -> str:
    """The text under a markdown heading, up to the next heading of the same or a higher level."""
    match = re.search(rf"^(#+) {re.escape(heading)}\s*$", text, re.M)
    assert match, f"docs/config.md has no heading {heading!r}"
    level = len(match.group(1))
    rest = text[match.end():]
    end = re.search(rf"^#{{1,{level}}} ", rest, re.M)
    return rest[:end.start()] if end else rest


@pytest.mark.parametrize("table, key", [(t, k) for t, keys in SCHEMA.items() for k in keys])
def test_every_config_key_is_documented_in_its_table(table, key):
    assert f"`{key}`" in _section(CONFIG_DOC, f"[{table}]"), f"[{table}] {key} is not in docs/config.md"


@pytest.mark.parametrize("builder, option", [(b, p) for b, f in BUILDERS.items()
                                             for p in inspect.signature(f).parameters])
def test_every_builder_option_is_documented(builder, option):
    paragraph = CONFIG_DOC.split(f"Builder `{builder}`:")[1].split("\n\n")[0]
    assert f"`{option}`" in paragraph, f"builder {builder!r} option {option!r} is not in docs/config.md"


@pytest.mark.parametrize("method, options", [("trf", TRF_OPTIONS), ("lbfgsb", LBFGSB_OPTIONS),
                                             ("gradient-descent", GRADIENT_DESCENT_OPTIONS),
                                             ("nelder-mead", NELDER_MEAD_OPTIONS)])
def test_every_method_option_is_documented(method, options):
    item = CONFIG_DOC.split(f"- `{method}`:")[1].split("\n- ")[0]
    missing = [name for name in options if f"`{name}`" not in item]
    assert not missing, f"options {missing} of method {method!r} are not in docs/config.md"


@pytest.mark.parametrize("document", DOCUMENTS, ids=lambda p: p.name)
def test_relative_links_lead_to_files_of_the_repository(document):
    for target in re.findall(r"\]\(([^)#\s]+)(?:#[^)]*)?\)", document.read_text()):
        if "://" not in target:
            assert (document.parent / target).exists(), f"{document.name} links to missing {target}"


@pytest.mark.slow          # 41 s in the fast suite on the shared machine (about 1/7 idle)
def test_the_first_example_gives_what_getting_started_shows(tmp_path):
    """docs/getting-started.md walks through examples/first: B resolved with the truth in its interval, A not
    (correlated with B), the misfit explained; with the estimate, the error is reported and moves A up, B down."""
    import json
    import shutil

    from frictionid.cli import main

    folder = tmp_path / "first"
    shutil.copytree(ROOT / "examples" / "first", folder)
    assert main(["simulate", str(folder / "truth.toml"), "--out", str(folder / "measured.csv")]) == 0
    assert main(["identify", str(folder / "identify.toml")]) == 0
    result = json.loads((folder / "runs/first/result.json").read_text())
    a, b = result["parameters"]["A"], result["parameters"]["B"]
    assert result["fit"]["consistent"] is True
    assert b["identifiable"] and b["ci95"][0] <= 0.15 <= b["ci95"][1]
    assert not a["identifiable"] and "correlated with B" in a["why"]
    doc = (ROOT / "docs" / "getting-started.md").read_text()
    assert f"B          {b['value']:.6f} +/- {b['stderr']:.6f}" in doc
    text = (folder / "identify.toml").read_text().replace('method = "trf"\n', 'model_error = "estimate"\n')
    (folder / "estimate.toml").write_text(text.replace('dir = "runs/first"', 'dir = "runs/estimate"'))
    assert main(["identify", str(folder / "estimate.toml")]) == 0
    shift = json.loads((folder / "runs/estimate/result.json").read_text())["fit"]["model_error"]["shift"]
    assert shift["A"] > 0 > shift["B"]
