"""frictionid's block model at the truth on the dense reference's points with pieces of its mesh refined that no
`[model]` option refines on its own: the source of the linear family's uz offset (docs/fit-quality.md; the
footprint's interior is the builder's ``interior_splits``).

    PYTHONPATH=src .venv/bin/python benchmarks/block_pieces.py NAME OPTIONS [PIECE=K ...] [--out DIR]

OPTIONS are ``[model]`` lines as for ``dense_acceptance.py --at-truth`` (e.g. ``'edge_splits = 4\\nedge_band =
0.5\\ninterface_splits = 4'``); each PIECE=K splits the intervals of one piece of the block mesh's layout
(:func:`frictionid.builders.block_mesh.layout`) into K equal parts, outside the bands the options refine:

- ``outer``: the plate's intervals outside the footprint and outside the edge band;
- ``plate_z`` / ``block_z``: the plate's / block's layers outside the interface band.

The layout is replaced for this process only (benchmark only; the builder's options are unchanged). Writes
``DIR/NAME/measured.csv`` (displacements and the force, the small-sliding check off) and prints the nodes, the
seconds and the process's peak; compare with ``dense_convergence.py fixture=tests/fixtures/dense_block NAME=DIR/NAME``
(``sink_press`` / ``sink_pull``: the change of the block faces' mean uz).
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import sys
from pathlib import Path

import frictionid.builders.block_mesh as block_mesh
from frictionid.builders.block_mesh import BLOCK_HEIGHT, BLOCK_SIDE, PLATE_THICKNESS, Bands, _graded, _split

import dense_acceptance

PIECES = ("outer", "plate_z", "block_z")


def split_layout(original, splits: dict[str, int]):
    """``original`` (:func:`frictionid.builders.block_mesh.layout`) with the pieces ``splits`` names split."""

    def layout(block_divisions, n_block_z, n_plate_z, grading=1.0, bands=Bands()):
        places = original(block_divisions, n_block_z, n_plate_z, grading, bands)
        half, changes = BLOCK_SIDE / 2, {}
        if "outer" in splits:
            if places.outer is None:
                sys.exit("outer: needs edge_splits > 1 (the plate outside the footprint as explicit positions)")
            middle = (places.outer[:-1] + places.outer[1:]) / 2
            changes["outer"] = _split(places.outer, middle - half >= bands.edge_band, splits["outer"])
        for piece, length in (("plate_z", PLATE_THICKNESS), ("block_z", BLOCK_HEIGHT)):
            if piece in splits:
                grid = getattr(places, piece)
                z = length * _graded(grid, grading, both_ends=False)
                changes[piece] = _split(grid, (z[:-1] + z[1:]) / 2 >= bands.interface_band, splits[piece])
        return dataclasses.replace(places, **changes)

    return layout


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("name")
    parser.add_argument("options", help="[model] lines, '\\n' between them")
    parser.add_argument("splits", nargs="*", metavar="PIECE=K", help=f"PIECE one of {', '.join(PIECES)}")
    parser.add_argument("--out", type=Path, default=Path("/tmp/block_pieces"))
    args = parser.parse_args(argv)
    splits = {}
    for item in args.splits:
        piece, _, k = item.partition("=")
        if piece not in PIECES or not k.isdigit() or int(k) < 1:
            parser.error(f"PIECE=K with PIECE one of {', '.join(PIECES)} and K >= 1, got {item!r}")
        splits[piece] = int(k)
    block_mesh.layout = split_layout(block_mesh.layout, splits)
    print(json.dumps({**dense_acceptance.at_truth(args.name, args.options, args.out, None), "splits": splits}))
    return 0


if __name__ == "__main__":
    sys.exit(main())
