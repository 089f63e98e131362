"""Running ccx: one isolated work directory per evaluation, no shell, a timeout, failures kept for inspection."""

from __future__ import annotations

import logging
import os
import shutil
import subprocess
import tempfile
from pathlib import Path

from ...errors import InputError, SolverError

log = logging.getLogger(__name__)
JOB = "job"
INSTALL_HINT = "install it with `apt-get install calculix-ccx` (Debian/Ubuntu) or set solver.ccx to its path"
_ERROR_LINES = 6


def find_ccx(executable: str = "ccx") -> str:
    """Absolute path of the ccx executable (a name looked up on PATH, or a path).

    Raises
    ------
    InputError
        If it cannot be found or is not executable, naming the setting and how to install it.
    """
    found = shutil.which(executable)
    if found is None:
        raise InputError(f"solver.ccx = {executable!r}: the CalculiX solver was not found (backend 'calculix'); "
                         f"{INSTALL_HINT}")
    return found


def _error_excerpt(text: str) -> str:
    """The '*ERROR' lines of a ccx log (and the lines after each), or its last lines."""
    lines = text.splitlines()
    hits = [i for i, line in enumerate(lines) if "*ERROR" in line]
    chosen = [lines[j].strip() for i in hits[:2] for j in range(i, min(i + 3, len(lines)))] if hits \
        else [line.strip() for line in lines[-_ERROR_LINES:]]
    return " ".join(line for line in chosen if line)


def run_ccx(deck: str, executable: str, timeout: float, work_root: str | Path | None = None,
            threads: int = 1) -> Path:
    """Write ``deck`` to a fresh work directory and run ccx there; returns the directory.

    The caller removes the directory when it has read the results. On a failure it is kept and named.

    Parameters
    ----------
    deck : the .inp text
    executable : path of ccx (see :func:`find_ccx`)
    timeout : float [s]
        The run is killed after this time.
    work_root : folder for the work directories (default: the system's temporary folder)
    threads : OpenMP threads of ccx (OMP_NUM_THREADS, CCX_NPROC_EQUATION_SOLVER)

    Raises
    ------
    SolverError
        If ccx cannot be started, exits with an error, prints an '*ERROR' or exceeds the timeout.
    """
    if work_root is not None:
        Path(work_root).mkdir(parents=True, exist_ok=True)
    work = Path(tempfile.mkdtemp(prefix="frictionid-ccx-", dir=work_root))
    (work / f"{JOB}.inp").write_text(deck)
    env = {**os.environ, "OMP_NUM_THREADS": str(threads), "CCX_NPROC_EQUATION_SOLVER": str(threads)}
    try:
        done = subprocess.run([executable, "-i", JOB], cwd=work, env=env, timeout=timeout,
                              capture_output=True, text=True, check=False)
    except subprocess.TimeoutExpired as exc:
        (work / "ccx.log").write_text(_text(exc.stdout) + _text(exc.stderr))
        raise SolverError(f"ccx did not finish within the timeout of {timeout:g} s (solver.timeout); "
                          f"work directory kept: {work}") from None
    except OSError as exc:
        raise SolverError(f"ccx ({executable}) could not be started: {exc.strerror}; work directory kept: "
                          f"{work}") from None
    (work / "ccx.log").write_text(done.stdout + done.stderr)
    if done.returncode != 0 or "*ERROR" in done.stdout:
        raise SolverError(f"ccx failed (exit status {done.returncode}): {_error_excerpt(done.stdout + done.stderr)}; "
                          f"work directory kept: {work} (see ccx.log there)")
    log.debug("ccx finished in %s", work)
    return work


def _text(value) -> str:
    if value is None:
        return ""
    return value.decode(errors="replace") if isinstance(value, bytes) else value


def remove_work(work: Path) -> None:
    """Delete a work directory whose results have been read."""
    shutil.rmtree(work, ignore_errors=True)
