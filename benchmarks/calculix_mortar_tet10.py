"""CalculiX 2.20's mortar contact types on quadratic tetrahedra (C3D10), against its face-to-face penalty contact
and the embedded solver: is one of them a penalty-free reference for the 3-D bolt?

The model: tests/element_models.py's coarse C3D10 block on a plate (``element_model("C3D10", folder)``: pressed
with 2,000 N, then pulled sideways into gross slip in 4 increments; four zones, mu 0.3 / 0.2 / 0.4 / 0.25). ccx
runs the product's deck (penalty 1e6 N/mm^3 normal and stick) and, for each TYPE given, the same deck with
``*CONTACT PAIR, ..., TYPE=<TYPE>`` and ``*SURFACE BEHAVIOR, PRESSURE-OVERCLOSURE=HARD`` (the *FRICTION line and
its stick slope kept). Printed: the final reactions (the pull's is the friction force; the problem is symmetric
about the pull's plane, so the lateral one is near zero) of the embedded solver and of each ccx run.

Run (from the repository's root):
    nice -n 10 .venv/bin/python benchmarks/calculix_mortar_tet10.py [TYPE ...]   (default: the four mortar types)
"""

import sys
import tempfile
import time
from pathlib import Path

import numpy as np

import _tests  # noqa: F401  (tests/ on the import path)
from element_models import element_model
from frictionid.backends.calculix.backend import CalculixBackend, CalculixSettings
from frictionid.backends.calculix.runner import run_ccx
from frictionid.backends.embedded import EmbeddedBackend
from frictionid.errors import SolverError

TYPES = ("MORTAR", "LINMORTAR", "PGLINMORTAR", "PGMORTAR")
STIFFNESS = 1e6


def main(types) -> None:
    with tempfile.TemporaryDirectory() as folder:
        model, mu = element_model("C3D10", Path(folder))
        embedded = EmbeddedBackend(model, np.zeros((0, 3)), ("ux",), []).problem.solve(mu)
        reference = embedded.reactions[embedded.stage_end(model.n_stages - 1)]
        labels = model.reaction_labels
        pull, lateral = labels.index("block_top.y"), labels.index("block_top.x")
        print(f"C3D10 block on plate, {model.mesh.n_nodes:,} nodes; final reactions [N] {labels}")
        print(f"  embedded: pull {reference[pull]:.2f}, lateral {reference[lateral]:.2f}")
        backend = CalculixBackend(model, None, (), None, CalculixSettings(normal_stiffness=STIFFNESS,
                                                                          stick_slope=STIFFNESS, work_dir=folder))
        coefficients = model.coefficients(mu)
        deck = backend.deck(coefficients)
        behaviour = f"*SURFACE BEHAVIOR, PRESSURE-OVERCLOSURE=LINEAR\n{STIFFNESS:.13g}\n"
        if behaviour not in deck or "TYPE=SURFACE TO SURFACE" not in deck:
            raise SystemExit("the deck's contact lines are not the expected ones; update this script")
        decks = [(f"SURFACE TO SURFACE, penalty {STIFFNESS:g}", deck)]
        decks += [(f"{t}, HARD", deck.replace("TYPE=SURFACE TO SURFACE", f"TYPE={t}").replace(
            behaviour, "*SURFACE BEHAVIOR, PRESSURE-OVERCLOSURE=HARD\n")) for t in types]
        for name, text in decks:
            start = time.perf_counter()
            try:
                work = run_ccx(text, backend.executable, 900, folder)
            except SolverError as exc:
                print(f"  ccx {name}: failed ({str(exc).splitlines()[0][:160]})")
                continue
            r = backend._read(work, coefficients, False, time.perf_counter() - start).reactions[-1]
            print(f"  ccx {name}: pull {r[pull]:.2f} ({100 * (r[pull] / reference[pull] - 1):+.2f} %), lateral "
                  f"{r[lateral]:.2f}; {time.perf_counter() - start:.0f} s wall", flush=True)


if __name__ == "__main__":
    main(tuple(a.upper() for a in sys.argv[1:]) or TYPES)
