"""Cross-check every config in this folder (block.toml, block_small_sliding.toml, block_tenth.toml, block2d.toml,
bolt.toml): both backends on the same
model, differences and time per forward solve, written to results.md.

Run: .venv/bin/python examples/crosscheck/run.py [CONFIG.toml ...]
"""

import os
import sys
from pathlib import Path

os.environ.setdefault("OMP_NUM_THREADS", "1")

from frictionid.config import read_config  # noqa: E402
from frictionid.crosscheck import cross_check_config  # noqa: E402
from frictionid.report.crosscheck import cross_check_table  # noqa: E402

HERE = Path(__file__).parent


def main(paths: list[str]) -> None:
    configs = [Path(p) for p in paths] or sorted(HERE.glob("*.toml"))
    tables = []
    for path in configs:
        table = cross_check_table(*cross_check_config(read_config(path, need=("model", "friction"))))
        print(table, flush=True)
        tables.append(table)
    (HERE / "results.md").write_text("# Embedded vs CalculiX\n\n" + "\n".join(tables))
    print(f"wrote {HERE / 'results.md'}")


if __name__ == "__main__":
    main(sys.argv[1:])
