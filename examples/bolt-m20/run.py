"""The paper's M20 bolt-nut study (sections 4.2-4.3, reference test 2 (docs/models.md)) from one command.

Same as `frictionid demo --out examples/bolt-m20/out` (what `make demo` runs); add --quick for coarse meshes.
The study itself is frictionid.studies.bolt: twin data from a finer mesh (noise-free and with 0.5 um DIC-like noise),
resolution before fitting, identification of the six thread zones from mu = 0.1 with the paper's gradient
descent and with trf, the paper's Fig. 9, the mesh sequence of the measured-point displacements and the thread
load shares against Sopwith. Outputs: see README.md beside this file.
"""

import sys
from pathlib import Path

from frictionid.cli import main

if __name__ == "__main__":
    sys.exit(main(["demo", "--out", str(Path(__file__).parent / "out"), *sys.argv[1:]]))
