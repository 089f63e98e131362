"""Modules stay small and named for what they own: none over 450 lines outside fem/ (scikit-fem's assembly and
the contact solver's numerics live there), and identification.py, the orchestration, under 300."""

from pathlib import Path

PACKAGE = Path(__file__).parents[1] / "src" / "frictionid"
LIMIT, ORCHESTRATION = 450, 300


def lines(path: Path) -> int:
    return len(path.read_text().splitlines())


def test_no_module_outside_fem_is_over_450_lines():
    sizes = {str(p.relative_to(PACKAGE)): lines(p) for p in PACKAGE.rglob("*.py") if "fem" not in p.parts}
    assert len(sizes) > 100                                 # the walk found the package
    assert not {name: n for name, n in sizes.items() if n > LIMIT}


def test_identification_is_orchestration_only():
    assert lines(PACKAGE / "identification.py") < ORCHESTRATION
