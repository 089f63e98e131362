"""Measurement points of the 3-D block (reference test 1: block [-5, 5] x [-5, 5] x [0, 10] on a plate)."""

import numpy as np

#: the 16 strain points of benchmarks/identify_block.py on the block's side faces near the contact [mm]
BLOCK_POINTS = np.array([[x, y, z] for z in (0.5, 1.5) for s in (-3.0, 3.0)
                         for x, y in ((-5.0, s), (5.0, s), (s, -5.0), (s, 5.0))])
