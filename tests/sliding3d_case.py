"""The seed's block test in 3-D for finite sliding against CalculiX (tests/test_sliding_calculix.py,
benchmarks/finite_sliding_3d.py): coefficients, DIC points and what is observed at them."""

import numpy as np

#: zones A, B, C, D
MU = np.array([0.35, 0.2, 0.45, 0.15])
#: the 16 block-face points of examples/crosscheck/block_points.csv and 8 on the plate's top around the block [mm]
POINTS = np.array([[sx * 5.0, sy * 3.0, z] for z in (0.5, 1.5) for sx in (-1, 1) for sy in (-1, 1)]
                  + [[sy * 3.0, sx * 5.0, z] for z in (0.5, 1.5) for sx in (-1, 1) for sy in (-1, 1)]
                  + [[x, y, 0.0] for x, y in ((-8, 0), (8, 0), (0, -8), (0, 8), (-7, -7), (7, 7), (-7, 7), (7, -7))])
REGIONS = ["block"] * 16 + ["plate"] * 8
QUANTITIES = ("ux", "uy", "uz")
