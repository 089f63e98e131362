"""The dense block reference's plate strains read two ways: the DIC's reading (a 2 mm virtual strain gauge over the
displacements interpolated on the face's elements) against ccx's own nodal strains (TOSTRAIN: extrapolated from
the integration points and averaged at the nodes, interpolated the same way and averaged over the same circle).

Per pair of consecutive levels of finished runs (tilt_ccx.py / tests/fixtures/dense_block/generate.py work folders),
the end of the pull's level difference of the plate's exx, eyy, exy in noise levels (2e-5), RMS over the plate
points, near the footprint (< 2.5 mm out) and away from it, for each reading; and per level the RMS of one
reading minus the other. Where the nodal strains converge and the VSG's do not, the DIC's reading of the field,
not the field, is what has not converged.

    PYTHONPATH=src .venv/bin/python benchmarks/dense_reading.py g4=/tmp/g4p g5=/tmp/g5p g6=/tmp/g6p

(names are tilt_ccx.py's level names: ``g<k>`` with its GRADED flags, or a level number).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

from _measure import emit
from dense_convergence import dense
from frictionid.backends.calculix.parse import read_frd

tilt, gen = dense.tilt, dense.tilt.gen
#: frd TOSTRAIN columns exx, eyy, ezz, exy, eyz, ezx (tensor shear): the plate top's in-plane ones
PLATE_COLUMNS = [0, 1, 3]
NEAR = 2.5


def level_of(name: str):
    return int(name) if name.isdigit() else name


def readings(level, work: Path, scale: float = 0.01, window: float = 2.0) -> tuple[np.ndarray, dict]:
    """(plate points (n, 3), {"vsg": (n, 3), "nodal": (n, 3)}) at the end of the pull: exx, eyy, exy."""
    plate, block, _ = tilt.meshes(level)
    frd = read_frd(work / f"{gen.JOB}.frd")
    name, axis, xyz = dense.face_points(0.6)[4]
    disp = frd.last_of_step("DISP", 2)
    u = dense.displacements(plate, block, {int(n): v[:3] / scale for n, v in zip(disp.nodes, disp.values)}, 2, xyz)
    vsg = dense.vsg_strains(xyz, u, 2, window)
    strain = frd.last_of_step("TOSTRAIN", 2)
    nodal = dense.displacements(plate, block, {int(n): v[PLATE_COLUMNS] / scale
                                               for n, v in zip(strain.nodes, strain.values)}, 2, xyz)
    centres = xyz[:, :2]
    averaged = np.array([nodal[np.hypot(*(centres - c).T) <= window / 2 + 1e-12].mean(0) for c in centres])
    return xyz, {"vsg": np.column_stack([vsg["exx"], vsg["eyy"], vsg["exy"]]), "nodal": averaged}


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("runs", nargs="+", help="level=work folder of a finished ccx run, coarse to fine")
    parser.add_argument("--out", type=Path, help="append the JSON lines here")
    args = parser.parse_args(argv)
    named = [(a.split("=", 1)[0], Path(a.split("=", 1)[1])) for a in args.runs]
    read = {name: readings(level_of(name), work) for name, work in named}
    for name, _ in named:
        d = (read[name][1]["nodal"] - read[name][1]["vsg"]) / dense.NOISE_E
        emit({"level": name, "nodal_minus_vsg_rms": round(float(np.sqrt(np.mean(d ** 2))), 2)}, args.out)
    for (a, _), (b, _) in zip(named, named[1:]):
        xyz = read[a][0]
        out = np.hypot(np.maximum(np.abs(xyz[:, 0]) - 5, 0), np.maximum(np.abs(xyz[:, 1]) - 5, 0))
        row = {"levels": [a, b]}
        for kind in ("vsg", "nodal"):
            d = (read[b][1][kind] - read[a][1][kind]) / dense.NOISE_E
            rms = lambda mask: round(float(np.sqrt(np.mean(d[mask] ** 2))), 2)
            row[kind] = {"rms": rms(out >= 0), "near_rms": rms(out < NEAR), "away_rms": rms(out >= NEAR)}
        emit(row, args.out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
