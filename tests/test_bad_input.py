"""Bad input through the command line, in-process: each case exits 2 with a message naming the file and the key or
column, without a traceback, and leaves every file of its folder as it was (nothing written, nothing changed).

Each case starts from a small valid identification (the plane-strain block2d model, its points on the block's
sides and the base, ux and uy at stage 2) and breaks one thing: the config (as tables, or as text), the data file,
the mesh, or the command's output path.
"""

import copy
import shutil
from dataclasses import dataclass, field
from pathlib import Path

import pytest
import tomli_w

from frictionid.cli import main

FIXTURES = Path(__file__).parent / "fixtures" / "user_block"
POINTS = {"L1": (-5.0, 0.5), "L2": (-5.0, 1.5), "R1": (5.0, 0.5), "R2": (5.0, 1.5), "B1": (-8.0, 0.0),
          "B2": (8.0, 0.0)}
REGIONS = {"L*": "block", "R*": "block", "B*": "base"}


def data_csv(rows=None, header="point,x,y,z,stage,force,ux,uy") -> str:
    """The measurement file: six points at stage 2 with small made-up values (bad input is refused before they
    matter)."""
    rows = rows if rows is not None else [f"{p},{x},{y},0.0,2,-0.03,0.001,-0.01" for p, (x, y) in POINTS.items()]
    return "# made-up values [mm]\n" + header + "\n" + "\n".join(rows) + "\n"


BASE = {"model": {"builder": "block2d", "mesh_size": 2.0},
        "friction": {"zones": {"A": 0.1, "B": 0.1}},
        "data": {"file": "measured.csv", "observables": ["ux", "uy"], "stages": [2], "noise": {"u": 0.0005},
                 "regions": REGIONS},
        "run": {"dir": "runs/bad"}}


@dataclass
class Case:
    """One bad input: ``edit`` changes the config tables, ``text`` replaces the config file, ``files`` adds or
    replaces files; ``argv`` (with {dir} for the folder) runs it; ``named`` must all appear in the message."""

    name: str
    named: tuple
    edit: object = None
    text: str | None = None
    files: dict = field(default_factory=dict)
    argv: tuple = ("identify", "{dir}/identify.toml")


def _set(dotted: str, value):
    def edit(tables):
        *path, key = dotted.split(".")
        table = tables
        for part in path:
            table = table.setdefault(part, {})
        if value is DELETE:
            table.pop(key)
        else:
            table[key] = value
    return edit


DELETE = object()
PLANE_MESH = {"builder": "mesh", "file": "plane.msh", "kind": "plane_strain", "stages": ["press", "pull"],
              "increments": [1, 2], "materials": {"base": {"E": 3500, "nu": 0.35}, "block": {"E": 71000, "nu": 0.33}},
              "supports": [{"boundary": "base_bottom", "components": ["x", "y"]}],
              "loads": [{"type": "force", "boundary": "block_top", "component": "y", "values": [-200.0, -200.0]},
                        {"type": "displacement", "boundary": "block_top", "component": "x", "values": [0.0, 0.05]}],
              "interfaces": [{"name": "block_base", "zones": ["A", "B"], "target": "base_top"}]}


def _mesh_model(change=None):
    def edit(tables):
        tables["model"] = copy.deepcopy(PLANE_MESH)
        if change:
            change(tables["model"])
    return edit


CASES = [
    # the config file itself
    Case("not TOML", ("identify.toml", "TOML"), text="[model\nbuilder = 'block2d'\n"),
    Case("unknown table", ("identify.toml", "[solvr]", "did you mean 'solver'"), edit=_set("solvr.threads", 2)),
    Case("unknown key friction", ("identify.toml", "friction.zone", "did you mean 'zones'"),
         edit=_set("friction.zone", {"A": 0.1})),
    Case("unknown key data", ("identify.toml", "data.nosie", "did you mean 'noise'"), edit=_set("data.nosie", {})),
    Case("unknown key solver", ("identify.toml", "solver.threds", "did you mean 'threads'"),
         edit=_set("solver.threds", 2)),
    Case("unknown key identify", ("identify.toml", "identify.max_iteration", "did you mean 'max_iterations'"),
         edit=_set("identify.max_iteration", 5)),
    Case("unknown key run", ("identify.toml", "run.worker", "did you mean 'workers'"), edit=_set("run.worker", 2)),
    Case("unknown key design", ("identify.toml", "design.point", "did you mean 'points'"),
         edit=_set("design.point", 4)),
    Case("unknown builder option", ("identify.toml", "mesh_sise", "did you mean 'mesh_size'"),
         edit=_set("model.mesh_sise", 1.0)),
    Case("unknown noise key", ("identify.toml", "data.noise.f", "did you mean 'force'"),
         edit=_set("data.noise", {"u": 0.0005, "f": 0.5})),
    Case("negative noise", ("identify.toml", "data.noise.u", "positive"), edit=_set("data.noise.u", -0.001)),
    Case("noise as text", ("identify.toml", "data.noise.u", "positive"), edit=_set("data.noise.u", "0.0005")),
    Case("builder option of the wrong type", ("identify.toml", "[model]", "mesh_size", "'1.0'"),
         edit=_set("model.mesh_size", "1.0")),
    Case("unknown builder", ("identify.toml", "builder", "blok"), edit=_set("model.builder", "blok")),
    Case("missing table", ("identify.toml", "missing table [data]"), edit=lambda t: t.pop("data")),
    Case("missing observables", ("identify.toml", "data.observables"), edit=_set("data.observables", DELETE)),
    Case("missing run.dir", ("identify.toml", "run.dir"), edit=_set("run.dir", DELETE)),
    Case("stages not a list", ("identify.toml", "data.stages"), edit=_set("data.stages", 2)),
    Case("stage as text", ("identify.toml", "data.stages", "'2'"), edit=_set("data.stages", ["2"])),
    Case("stage the model lacks", ("identify.toml", "data.stages", "7"), edit=_set("data.stages", [7])),
    Case("unknown observable", ("identify.toml", "data.observables", "uxx"), edit=_set("data.observables", ["uxx", "uy"])),
    Case("unknown zone", ("identify.toml", "friction", "Q"), edit=_set("friction.zones", {"A": 0.1, "Q": 0.1})),
    Case("zone left out", ("identify.toml", "friction", "B"), edit=_set("friction.zones", {"A": 0.1})),
    Case("bounds exclude the start", ("identify.toml", "A", "0.9"),
         edit=lambda t: t["friction"].update(zones={"A": 0.9, "B": 0.1}, bounds=[0.0, 0.5])),
    Case("bounds reversed", ("identify.toml", "bounds"), edit=_set("friction.bounds", [1.0, 0.0])),
    Case("unknown jacobian", ("identify.toml", "identify.jacobian", "exact"), edit=_set("identify.jacobian", "exact")),
    Case("unknown method", ("identify.toml", "method", "newton"), edit=_set("identify.method", "newton")),
    Case("iterations as text", ("identify.toml", "identify.max_iterations"),
         edit=_set("identify.max_iterations", "50")),
    Case("unknown loss", ("identify.toml", "identify.loss", "l1"), edit=_set("identify.loss", "l1")),
    Case("no workers", ("identify.toml", "run.workers"), edit=_set("run.workers", 0)),
    Case("zero timeout", ("identify.toml", "solver.timeout must be > 0"), edit=_set("solver.timeout", 0)),
    Case("zero resolution", ("identify.toml", "identify.resolution must be > 0"),
         edit=_set("identify.resolution", 0.0)),
    Case("negative retries", ("identify.toml", "run.retries must be >= 0"), edit=_set("run.retries", -1)),
    Case("two profile points", ("identify.toml", "identify.profile_points must be >= 3"),
         edit=_set("identify.profile_points", 2)),
    Case("negative strain window", ("identify.toml", "data.strain_window must be > 0"),
         edit=_set("data.strain_window", -0.5)),
    Case("no design points", ("identify.toml", "design.points must be >= 1"), edit=_set("design.points", 0),
         argv=("design", "{dir}/identify.toml")),
    Case("unknown backend", ("identify.toml", "abaqus"), edit=_set("solver.backend", "abaqus")),
    Case("missing ccx", ("identify.toml", "ccx", "/nonexistent/ccx"),
         edit=lambda t: t.update(solver={"backend": "calculix", "ccx": "/nonexistent/ccx"},
                                 identify={"jacobian": "central"})),
    Case("unknown factorisation", ("identify.toml", "solver.factorisation", "pardiso"),
         edit=_set("solver.factorisation", "pardiso")),
    Case("force observed without its noise", ("identify.toml", "force is observed with ux, uy", "noise = { force = 1.0 }"),
         edit=_set("data.observables", ["ux", "uy", "force"])),
    Case("unknown region", ("identify.toml", "data.regions", "blok"), edit=_set("data.regions", {"*": "blok"})),
    Case("region key matching no point", ("identify.toml", "data.regions", "Q*"),
         edit=_set("data.regions", {**REGIONS, "Q*": "base"})),
    Case("run.dir is a file", ("identify.toml", "run.dir", "measured.csv"), edit=_set("run.dir", "measured.csv")),
    Case("run.dir under a file", ("identify.toml", "run.dir", "measured.csv"),
         edit=_set("run.dir", "measured.csv/run")),
    Case("unknown key of a file entry", ("identify.toml", "pth", "did you mean 'path'"),
         edit=_set("data.file", [{"path": "measured.csv", "stage": 2, "pth": "x"}])),
    Case("unknown key of a transform", ("identify.toml", "transform", "rotation_dg"),
         edit=_set("data.transform", {"rotation_dg": [0.0, 0.0, 10.0]})),
    Case("unknown option of the method", ("identify.toml", "xtol_"), edit=_set("identify.options", {"xtol_": 1e-8})),
    Case("unknown reaction key", ("identify.toml", "data.reactions.clamps", "did you mean 'clamp'"),
         edit=_set("data.reactions", {"clamps": "block_top.y"})),
    Case("unknown key of a material", ("identify.toml", "Nu", "did you mean 'nu'"),
         edit=_mesh_model(lambda m: m["materials"]["base"].update(Nu=0.3))),
    Case("unknown key of an interface", ("identify.toml", "targt", "did you mean 'target'"),
         edit=_mesh_model(lambda m: m["interfaces"][0].update(targt="base_top"))),
    Case("unknown key of a support", ("identify.toml", "component", "did you mean 'components'"),
         edit=_mesh_model(lambda m: m["supports"][0].update(component=["x"]))),
    # data files
    Case("data file missing", ("missing.csv",), edit=_set("data.file", "missing.csv")),
    Case("column x missing", ("measured.csv", "x"),
         files={"measured.csv": data_csv([f"{p},{y},0.0,2,-0.03,0.001,-0.01" for p, (x, y) in POINTS.items()],
                                         header="point,y,z,stage,force,ux,uy")}),
    Case("NaN coordinate", ("measured.csv:3", "column 'x'"),
         files={"measured.csv": data_csv(["L1,nan,0.5,0.0,2,-0.03,0.001,-0.01"]
                                         + [f"{p},{x},{y},0.0,2,-0.03,0.001,-0.01" for p, (x, y) in
                                            list(POINTS.items())[1:]])}),
    Case("text in a number column", ("measured.csv:4", "column 'ux'"),
         files={"measured.csv": data_csv([f"{p},{x},{y},0.0,2,-0.03,{'abc' if p == 'L2' else 0.001},-0.01"
                                          for p, (x, y) in POINTS.items()])}),
    Case("a short row", ("measured.csv:5", "header"),
         files={"measured.csv": data_csv([f"{p},{x},{y},0.0,2,-0.03,0.001" + ("" if p == "R1" else ",-0.01")
                                          for p, (x, y) in POINTS.items()])}),
    Case("empty data file", ("measured.csv",), files={"measured.csv": ""}),
    Case("a point twice at a stage", ("measured.csv", "L1"),
         files={"measured.csv": data_csv([f"{p},{x},{y},0.0,2,-0.03,0.001,-0.01" for p, (x, y) in POINTS.items()]
                                         + ["L1,-5.0,0.5,0.0,2,-0.03,0.001,-0.01"])}),
    Case("no values of the observed stage", ("measured.csv", "stages"), edit=_set("data.stages", [1])),
    # meshes
    Case("mesh file missing", ("identify.toml", "nowhere.msh"), edit=_mesh_model(lambda m: m.update(file="nowhere.msh"))),
    Case("mesh file not a mesh", ("plane.msh",), edit=_mesh_model(), files={"plane.msh": "this is not a mesh\n"}),
    Case("unknown boundary of a mesh", ("identify.toml", "base_botom"),
         edit=_mesh_model(lambda m: m["supports"][0].update(boundary="base_botom"))),
    Case("unknown material region", ("identify.toml", "steel"),
         edit=_mesh_model(lambda m: m["materials"].update(steel={"E": 2e5, "nu": 0.3}))),
    Case("stage values of the wrong length", ("identify.toml", "values"),
         edit=_mesh_model(lambda m: m["loads"][0].update(values=[-200.0]))),
    # output paths of the other commands
    Case("simulate onto its data file", ("measured.csv", "input"),
         argv=("simulate", "{dir}/identify.toml", "--out", "{dir}/measured.csv")),
    Case("simulate onto its config", ("identify.toml", "input"),
         argv=("simulate", "{dir}/identify.toml", "--out", "{dir}/identify.toml")),
    Case("simulate under a file", ("measured.csv", "no folder"),
         argv=("simulate", "{dir}/identify.toml", "--out", "{dir}/measured.csv/out.csv")),
    Case("simulate onto a folder", ("runs", "folder"), files={"runs/keep.txt": "kept\n"},
         argv=("simulate", "{dir}/identify.toml", "--out", "{dir}/runs")),
    Case("crosscheck onto its config", ("identify.toml", "input"),
         argv=("crosscheck", "{dir}/identify.toml", "--out", "{dir}/identify.toml")),
    Case("design into a file", ("measured.csv", "not a folder"),
         argv=("design", "{dir}/identify.toml", "--out", "{dir}/measured.csv")),
]


def test_a_noise_no_observable_uses_is_a_warning_naming_the_file_and_key(tmp_path, capsys, caplog):
    """Legal but suspicious: the strain noise given for a displacement-only fit (the u noise missing). The
    warning comes when the config is read, before anything is built; here the missing data file then stops the
    run, so the folder stays as it was."""
    case = Case("noise of no observable", (), edit=lambda t: t["data"].update(noise={"e": 1e-5}, file="gone.csv"))
    _prepare(tmp_path, case)
    before = _snapshot(tmp_path)
    assert main(["identify", str(tmp_path / "identify.toml")]) == 2
    warning = " ".join(r.getMessage() for r in caplog.records if r.levelname == "WARNING")
    assert "identify.toml: data.noise gives e, but no observed quantity" in warning and "'ux', 'uy'" in warning
    assert "gone.csv" in capsys.readouterr().err and _snapshot(tmp_path) == before


def _snapshot(folder: Path) -> dict:
    return {p.relative_to(folder): (p.stat().st_mtime_ns, p.read_bytes() if p.is_file() else None)
            for p in sorted(folder.rglob("*"))}


def _prepare(folder: Path, case: Case) -> None:
    tables = copy.deepcopy(BASE)
    if case.edit is not None:
        case.edit(tables)
    shutil.copy(FIXTURES / "plane.msh", folder / "plane.msh")
    (folder / "measured.csv").write_text(data_csv())
    (folder / "identify.toml").write_text(case.text if case.text is not None else tomli_w.dumps(tables))
    for name, text in case.files.items():
        (folder / name).parent.mkdir(parents=True, exist_ok=True)
        (folder / name).write_text(text)


@pytest.mark.parametrize("case", CASES, ids=[c.name for c in CASES])
def test_bad_input_exits_2_naming_the_file_and_key_and_changes_nothing(case, tmp_path, capsys):
    _prepare(tmp_path, case)
    before = _snapshot(tmp_path)
    code = main([a.replace("{dir}", str(tmp_path)) for a in case.argv])
    err = capsys.readouterr().err
    assert code == 2, err
    assert err.startswith("frictionid: error:") and "Traceback" not in err
    for word in case.named:
        assert word in err, f"{word!r} not in {err!r}"
    assert _snapshot(tmp_path) == before


def test_the_corpus_is_at_least_forty_cases_and_its_base_runs(tmp_path, capsys):
    """Every case breaks a config that is valid: the unbroken one passes every check and solves (simulate)."""
    assert len(CASES) >= 40
    _prepare(tmp_path, Case("valid", ()))
    assert main(["simulate", str(tmp_path / "identify.toml"), "--out", str(tmp_path / "new" / "sim.csv")]) == 0
    assert (tmp_path / "new" / "sim.csv").is_file()
