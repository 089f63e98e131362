"""config.py: every table validated once, defaults filled, each mistake an InputError naming file and key."""

import pytest

from frictionid.config import SCHEMA, TYPES, config_from_dict, read_config
from frictionid.errors import InputError
from helpers import write_config

MINIMAL = {"model": {"builder": "block2d"}, "friction": {"zones": {"A": 0.1, "B": 0.1}}}


def test_a_minimal_config_gets_every_default_of_its_tables():
    config = config_from_dict(MINIMAL)
    for table in ("identify", "solver", "design"):
        for key, default in SCHEMA[table].items():
            if default is not None:
                assert getattr(getattr(config, table), key) == default, f"{table}.{key}"
    assert config.identify.method == "trf" and config.solver.backend == "embedded"
    assert config.friction["bounds"] == [0.0, 1.0]


def test_a_file_and_its_tables_give_the_same_config(tmp_path):
    path = write_config(tmp_path / "c.toml", **MINIMAL, identify={"max_iterations": 7})
    from_file = read_config(path)
    from_dict = config_from_dict({**MINIMAL, "identify": {"max_iterations": 7}})
    assert from_file.identify == from_dict.identify and from_file.friction == from_dict.friction
    assert from_file.text == path.read_text()


@pytest.mark.parametrize("tables, words", [
    ({"identfy": {}}, ["unknown table [identfy] (did you mean 'identify'?)"]),
    ({"identify": {"max_iteration": 3}}, ["unknown key identify.max_iteration (did you mean 'max_iterations'?)"]),
    ({"identify": {"max_iterations": "many"}}, ["identify.max_iterations", "a whole number"]),
    ({"solver": {"backend": 3}}, ["solver.backend"]),
    ({"run": {"workers": 2.5}}, ["run.workers"]),
], ids=["unknown table", "unknown key", "wrong type", "backend not text", "workers not whole"])
def test_a_mistake_names_the_file_and_the_key(tmp_path, tables, words):
    path = write_config(tmp_path / "bad.toml", **{**MINIMAL, **tables})
    with pytest.raises(InputError) as error:
        read_config(path)
    message = str(error.value)
    assert message.startswith(str(path)) and all(word in message for word in words), message


def test_a_missing_table_or_required_key_is_named(tmp_path):
    with pytest.raises(InputError, match=r"missing table \[friction\]"):
        config_from_dict({"model": {"builder": "block2d"}})
    with pytest.raises(InputError, match="missing key data.stages"):
        config_from_dict({**MINIMAL, "data": {"file": "m.csv", "observables": ["ux"]}},
                         need=("model", "friction", "data"))


def test_every_typed_key_belongs_to_a_table_of_the_schema():
    for dotted in TYPES:
        table, key = dotted.split(".", 1)
        assert key in SCHEMA[table], dotted
