"""The export corpus (issue 27): every DIC program's files, written in the layouts public sources give, read in
their camera frames to the numbers of the generic CSV (coordinates, values, strain measures, invalid points,
forces, two stages); check-data names each format; the three layouts added for issue 27 identify like the generic
CSV."""

import json
import re
import tomllib
from pathlib import Path

import numpy as np
import pytest

from frictionid.cli import main
from frictionid.data import read_measurements
from frictionid.data.sources import read_sources
from frictionid.options import DataSpec
from fixtures.dic import corpus
from helpers.config import with_data

ROOT = Path(__file__).parents[1]
FIXTURES = ROOT / "tests" / "fixtures" / "dic"
CORPUS = FIXTURES / "corpus"

#: exports carry values to 17 digits (ARAMIS's fixed-width fields fewer: the program's tolerance); a frame and
#: unit, strain measure conversions cost a few ulp
RTOL = 1e-12


#: a number in an export's text, its decimal mark a point or (GOM's German layout) a comma
NUMBER = re.compile(r"([-+]?(?:\d+[.,]\d+|\d+\.|\.\d+|\d+)(?:[eE][-+]?\d+)?)")


def text_differences(new: str, old: str, rtol: float = RTOL) -> list[str]:
    """Where two exports' texts differ: any character outside the numbers, or a number beyond ``rtol`` (the last
    of 17 digits moves with the NumPy release and the processor the frame's rotation ran on)."""
    a, b = NUMBER.split(new), NUMBER.split(old)
    if len(a) != len(b):
        return [f"{len(a) // 2} numbers, was {len(b) // 2}"]
    return [f"{x!r}, was {y!r}" for i, (x, y) in enumerate(zip(a, b))
            if (x != y if i % 2 == 0 else not np.isclose(*(float(t.replace(',', '.')) for t in (x, y)), rtol=rtol,
                                                          atol=1e-15))]


def test_text_differences_see_a_change():
    assert text_differences("x 1.0000000000000002 y\n", "x 1.0000000000000001 y\n") == []
    assert text_differences("x 1.000001 y\n", "x 1.0 y\n") == ["'1.000001', was '1.0'"]
    assert text_differences("x 1.0 z\n", "x 1.0 y\n") == ["' z\\n', was ' y\\n'"]
    assert text_differences("x 1.0 2 y", "x 1.0 y") == ["2 numbers, was 1"]
    assert text_differences("0,78613374722179;1", "0,786133747221789;1") == []              # a decimal comma
    assert text_differences("0,7861;1", "0,7862;1") == ["'0,7861', was '0,7862'"]


def test_the_corpus_is_what_its_writer_writes(tmp_path):
    corpus.main(tmp_path)
    written = sorted(p.name for p in tmp_path.iterdir())
    assert written == sorted(p.name for p in CORPUS.iterdir() if p.name != "README.md")
    for name in written:
        # latin-1 maps every byte to one character: the programs' own encodings (a degree sign in one) compare as written
        found = text_differences(*((folder / name).read_bytes().decode("latin-1") for folder in (tmp_path, CORPUS)))
        assert not found, (name, found[:5])


def entries(name: str, folder: Path = CORPUS, force: bool = True) -> list[dict]:
    """The [data] file tables of a program's two stage files: stage, camera frame, the force where the file has
    none."""
    program = corpus.PROGRAMS[name]
    generic = read_measurements(CORPUS / "generic.csv")
    return [{"path": str(folder / program.file.format(stage=s)), "stage": s, "transform": program.transform,
             **({"force": generic.stage_force(s)} if force and not program.force_in_file else {})}
            for s in (1, 2)]


@pytest.mark.parametrize("name", list(corpus.PROGRAMS))
def test_each_program_reads_to_the_generic_numbers(name, tmp_path):
    program = corpus.PROGRAMS[name]
    generic = read_measurements(CORPUS / "generic.csv")
    labels = corpus.write_program(tmp_path, name, generic)           # the labels the reader must give
    sources = read_sources(DataSpec.from_table({"file": entries(name), "strain": program.strain}), Path)
    m = sources.measurements
    assert m.points == tuple(labels[1] + labels[2])
    assert np.array_equal(m.stage, generic.stage)
    assert np.array_equal(m.force, generic.force)                    # from the file (ARAMIS) or the entry
    coordinates, values = program.tolerance
    size = float(np.abs(generic.coordinates).max())
    assert np.max(np.abs(m.coordinates - generic.coordinates)) <= coordinates + RTOL * size
    assert set(generic.quantities) <= set(m.quantities)
    for q in generic.quantities:
        scale = float(np.abs(generic.values[q]).max())
        assert np.max(np.abs(m.values[q] - generic.values[q])) <= values + RTOL * scale, q
    assert [f["format"] for f in sources.files] == [program.format] * 2
    assert all(f["rows"] - f["valid"] == program.n_invalid == sum(f["dropped"].values()) for f in sources.files)


@pytest.mark.parametrize("name", list(corpus.PROGRAMS))
def test_check_data_names_the_format_of_each_file(name, capsys):
    program = corpus.PROGRAMS[name]
    for stage in (1, 2):
        assert main(["check-data", str(CORPUS / program.file.format(stage=stage))]) == 0
        out = capsys.readouterr().out
        assert f": {program.format} export (" in out
        assert ("needed to identify: [data] strain" in out) == (program.strain is not None)


def test_deformed_coordinates_are_stated_and_reported_in_result_data(capsys):
    assert main(["check-data", str(CORPUS / "gom_correlate_2.csv")]) == 0
    out = capsys.readouterr().out
    assert "coordinates: deformed positions" in out and "x = x - displacement_x" in out
    assert main(["check-data", str(CORPUS / "aramis_nodemap_2.txt")]) == 0
    out = capsys.readouterr().out
    assert "coordinates: reference (undeformed) positions" in out and "force 1800.0 N from the metadata" in out


def test_a_matchid_2024_export_without_strain_measure_is_checked_and_the_key_named(capsys):
    assert main(["check-data", str(CORPUS / "matchid2024_1.csv")]) == 0
    out = capsys.readouterr().out
    assert "needed to identify: [data] strain" in out and "points: 12 valid of 13 rows" in out


def _identify(folder: Path, name: str, **data) -> dict:
    assert main(["identify", str(with_data(folder, name, **data))]) == 0
    return json.loads((folder / "runs" / name / "result.json").read_text())


@pytest.fixture(scope="module")
def reference(first):
    return _identify(first, "corpus_generic")


@pytest.mark.slow          # 94 s for the eight layouts in the fast suite on the shared machine (about 1/7 idle)
@pytest.mark.parametrize("name", ["matchid2023", "aramis", "gom_correlate"])
def test_the_new_layouts_identify_like_the_generic_csv(name, first, reference):
    """examples/first's twin (two stages) written in each layout, in a rotated camera frame, with an invalid
    point per file: the coefficients of the generic CSV to 1e-9, as many observations."""
    measured = read_measurements(first / "measured.csv")
    labels = corpus.write_program(first, name, measured)
    assert labels[1] == labels[2]
    regions = tomllib.loads((first / "identify.toml").read_text())["data"]["regions"]
    renamed = {new: regions.get(old, regions["*"]) for old, new in
               zip(measured.select(stages=[1]).points, labels[1])}
    files = [{**e, "path": Path(e["path"]).name} for e in entries(name, first, force=False)]
    result = _identify(first, f"corpus_{name}", file=files, regions=renamed,
                       **({"strain": corpus.PROGRAMS[name].strain} if corpus.PROGRAMS[name].strain else {}))
    assert result["fit"]["n_obs"] == reference["fit"]["n_obs"]
    for zone, p in reference["parameters"].items():
        assert abs(result["parameters"][zone]["value"] - p["value"]) <= 1e-9, zone
    assert [f["format"] for f in result["data"]["files"]] == [corpus.PROGRAMS[name].format] * 2
    deformed = name != "aramis"
    assert all(f["coordinates"].startswith("deformed") == deformed for f in result["data"]["files"])
