"""Schur complements and solves by MUMPS (the sequential double-precision library of the python-mumps 0.0.2 wheel).

For a symmetric positive definite K and the dofs s, MUMPS's multifrontal factorisation of the interior i (in
METIS's nested-dissection order; with a Schur complement this build orders by AMD where SCOTCH or PORD is asked
for: 1.8 times the factor entries on the 3-D bolt's bolt, docs/bolt-study.md) returns the dense Schur complement

    S = K_ss - K_si K_ii^-1 K_is,

with s eliminated last inside the factorisation (ICNTL(19)), so the interior is ordered for fill alone; the
factor of K_ii is kept for solves: K^-1 b by MUMPS's reduction (ICNTL(26) = 1: y_s = b_s - K_si K_ii^-1 b_i), a
dense solve with S and the expansion (ICNTL(26) = 2). Once that factor is freed (the condensation frees it before
its dense part) and S's Cholesky factor kept, a solve factorises K_ii alone (:meth:`SchurFactor.free`): no Schur
complement made again, no dense factorisation of it.

The wheel's own Python module is compiled against NumPy 1 and does not import under NumPy 2; its bundled
libraries (MUMPS 5.2.1, SCOTCH, METIS, PORD, OpenBLAS) do, and are called here through ctypes with the C structure
of MUMPS 5.2 (dmumps_c.h; the field list follows mumpspy's, MIT licence). The library's version string, which
MUMPS writes into the structure, is checked at every initialisation.
"""

from __future__ import annotations

import ctypes
import dataclasses
import importlib.util
import logging
import time
from dataclasses import dataclass
from functools import cache
from pathlib import Path

import numpy as np
import scipy.linalg as la
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components

from .threads import cholesky_threads

log = logging.getLogger(__name__)

VERSION = "5.2.1"
#: the ordering BodySchur asks for by default ("auto": MUMPS picks; METIS on every 3-D model measured)
ORDERING = "auto"
#: MUMPS's orderings of the interior (ICNTL(7)); "auto" lets MUMPS choose
ORDERINGS = {"amd": 0, "amf": 2, "scotch": 3, "pord": 4, "metis": 5, "qamd": 6, "auto": 7}

_INT, _INT8, _REAL = ctypes.c_int, ctypes.c_int64, ctypes.c_double
_P_INT, _P_REAL = ctypes.POINTER(_INT), ctypes.POINTER(_REAL)


class _Struc(ctypes.Structure):
    """DMUMPS_STRUC_C of MUMPS 5.2 (dmumps_c.h)."""

    _fields_ = [
        ("sym", _INT), ("par", _INT), ("job", _INT), ("comm_fortran", _INT),
        ("icntl", _INT * 60), ("keep", _INT * 500), ("cntl", _REAL * 15), ("dkeep", _REAL * 230),
        ("keep8", _INT8 * 150), ("n", _INT), ("nz_alloc", _INT),
        ("nz", _INT), ("nnz", _INT8), ("irn", _P_INT), ("jcn", _P_INT), ("a", _P_REAL),
        ("nz_loc", _INT), ("nnz_loc", _INT8), ("irn_loc", _P_INT), ("jcn_loc", _P_INT), ("a_loc", _P_REAL),
        ("nelt", _INT), ("eltptr", _P_INT), ("eltvar", _P_INT), ("a_elt", _P_REAL),
        ("perm_in", _P_INT), ("sym_perm", _P_INT), ("uns_perm", _P_INT),
        ("colsca", _P_REAL), ("rowsca", _P_REAL), ("colsca_from_mumps", _INT), ("rowsca_from_mumps", _INT),
        ("rhs", _P_REAL), ("redrhs", _P_REAL), ("rhs_sparse", _P_REAL), ("sol_loc", _P_REAL), ("rhs_loc", _P_REAL),
        ("irhs_sparse", _P_INT), ("irhs_ptr", _P_INT), ("isol_loc", _P_INT), ("irhs_loc", _P_INT),
        ("nrhs", _INT), ("lrhs", _INT), ("lredrhs", _INT), ("nz_rhs", _INT), ("lsol_loc", _INT),
        ("nloc_rhs", _INT), ("lrhs_loc", _INT),
        ("schur_mloc", _INT), ("schur_nloc", _INT), ("schur_lld", _INT),
        ("mblock", _INT), ("nblock", _INT), ("nprow", _INT), ("npcol", _INT),
        ("info", _INT * 80), ("infog", _INT * 80), ("rinfo", _REAL * 40), ("rinfog", _REAL * 40),
        ("deficiency", _INT), ("pivnul_list", _P_INT), ("mapping", _P_INT),
        ("size_schur", _INT), ("listvar_schur", _P_INT), ("schur", _P_REAL),
        ("instance_number", _INT), ("wk_user", _P_REAL),
        ("version_number", ctypes.c_char * 32),
        ("ooc_tmpdir", ctypes.c_char * 256), ("ooc_prefix", ctypes.c_char * 64),
        ("write_problem", ctypes.c_char * 256), ("lwk_user", _INT),
        ("save_dir", ctypes.c_char * 256), ("save_prefix", ctypes.c_char * 256),
        ("metis_options", _INT * 40),
    ]


#: the wheel's libraries that libdmumps_seq needs, in the order they need each other (they carry no search path
#: to their own folder, so each is loaded globally before the ones that need it)
_DEPENDENCIES = ("libquadmath", "libgfortran", "libopenblas", "libmetis", "libscotcherr", "libscotch-",
                 "libesmumps", "libpord_seq", "libmumps_common_seq", "libdmumps_seq")


def _libraries_folder() -> Path | None:
    spec = importlib.util.find_spec("mumps")          # finds the package without importing it
    if spec is None or spec.origin is None:
        return None
    folder = Path(spec.origin).parent.parent / "python_mumps.libs"
    return folder if folder.is_dir() else None


@cache
def _library():
    folder = _libraries_folder()
    if folder is None:
        raise ImportError("MUMPS is not installed (pip install python-mumps==0.0.2)")
    for prefix in _DEPENDENCIES:
        found = sorted(folder.glob(prefix + "*.so*"))
        if not found:
            raise ImportError(f"{prefix}*.so is missing from {folder}")
        lib = ctypes.CDLL(str(found[0]))          # local: its METIS must not serve pymetis or CHOLMOD
    lib.dmumps_c.argtypes = [ctypes.POINTER(_Struc)]
    lib.dmumps_c.restype = None
    return lib


def available() -> bool:
    """Whether the MUMPS library of the python-mumps wheel can be loaded."""
    try:
        _library()
    except (OSError, ImportError):
        return False
    return True


class MumpsError(ArithmeticError):
    """MUMPS stopped with INFOG(1) < 0 (-10: numerically singular; -13, -8, -9: memory)."""


@dataclass(frozen=True)
class Statistics:
    """What MUMPS reports of one factorisation: ordering, factor entries, memory [MB] and flops."""

    ordering: str
    factor_entries: int
    estimated_mb: int       # INFOG(17): estimated total memory of the in-core factorisation
    used_mb: int            # INFOG(22): memory the factorisation used
    flops: float            # RINFOG(3): flops of the elimination
    schur_size: int
    seconds: float = 0.0    # wall time of MUMPS's analysis and factorisation and the dense Cholesky of S
    cpu_seconds: float = 0.0   # the same, CPU time of all the process's threads


def _entries(value: int) -> int:
    return value if value >= 0 else -value * 1_000_000       # MUMPS gives large counts in millions, negated


class SchurFactor:
    """MUMPS's factor of a symmetric positive definite K (n, n) with the dofs ``schur`` eliminated last: the dense
    Schur complement :attr:`schur` onto them and solves with K.

    Raises :class:`MumpsError` where MUMPS fails (a matrix that is not positive definite among them). The MUMPS
    instance is freed by :meth:`free` or when the object is collected; pickled without it, made again at the
    first solve after unpickling.
    """

    def __init__(self, K: sp.spmatrix, schur: np.ndarray, ordering: str = "auto", factorise: bool = True):
        if ordering not in ORDERINGS:
            raise ValueError(f"`ordering` must be one of {', '.join(ORDERINGS)}, got {ordering!r}")
        lower = sp.tril(sp.coo_matrix(K)).tocoo()
        self.n = K.shape[0]
        self.ordering = ordering
        self.schur_dofs = np.asarray(schur, dtype=int)
        self._rows = (lower.row + 1).astype(np.int32)
        self._cols = (lower.col + 1).astype(np.int32)
        self._data = lower.data.astype(float)
        self._struc = None
        self._interior = None
        self.schur_cholesky, self.stats = self._factor() if factorise else (None, None)

    def __getstate__(self):
        return {**self.__dict__, "_struc": None, "schur_cholesky": None, "_interior": None}

    def __del__(self):
        try:
            self.free()
        except Exception:          # noqa: BLE001 - at interpreter exit the library may be gone already
            pass

    def free(self, schur: bool = False) -> None:
        """Release MUMPS's memory (the factor) and with ``schur`` the Schur complement's factor. A later solve
        factorises again: the interior K_ii alone where the Schur complement's factor is kept (its MUMPS factor
        then kept for the next solves, until freed), else the whole as at first."""
        if getattr(self, "_struc", None) is not None:
            self._struc.job = -2
            _library().dmumps_c(ctypes.byref(self._struc))
            self._struc = None
        interior = getattr(self, "_interior", None)
        if interior is not None:
            interior[0].free()
        self._interior = None
        if schur:
            self.schur_cholesky = None

    def _call(self, job: int) -> None:
        self._struc.job = job
        _library().dmumps_c(ctypes.byref(self._struc))
        info = self._struc.infog
        if info[0] < 0:
            raise MumpsError(f"MUMPS stopped with INFOG(1) = {info[0]}, INFOG(2) = {info[1]} (job {job})")

    def _instance(self) -> _Struc:
        """A MUMPS instance with this matrix, ordering and Schur dofs set (before the analysis)."""
        s = self._struc = _Struc()
        s.sym, s.par, s.comm_fortran = 1, 1, -987654          # SPD; the host works; no MPI (sequential library)
        self._call(-1)
        if s.version_number.decode().strip() != VERSION:
            raise ImportError(f"MUMPS {s.version_number.decode()!r} found, the structure here is {VERSION}'s")
        for k in (1, 2, 3):
            s.icntl[k - 1] = 0                                 # no messages on Fortran's units
        s.icntl[6] = ORDERINGS[self.ordering]                  # ICNTL(7)
        s.n, s.nnz, s.nz = self.n, len(self._data), 0
        s.irn = self._rows.ctypes.data_as(_P_INT)
        s.jcn = self._cols.ctypes.data_as(_P_INT)
        s.a = self._data.ctypes.data_as(_P_REAL)
        self._listvar = (self.schur_dofs + 1).astype(np.int32)
        m = len(self.schur_dofs)
        if m:
            s.icntl[18] = 1                                    # ICNTL(19): centralised Schur complement
            s.size_schur, s.schur_lld = m, m
            s.listvar_schur = self._listvar.ctypes.data_as(_P_INT)
        return s

    def _factor(self):
        start, cpu = time.perf_counter(), time.process_time()
        L, stats = self._factor_timed()
        return L, dataclasses.replace(stats, seconds=time.perf_counter() - start,
                                      cpu_seconds=time.process_time() - cpu)

    def _factor_timed(self):
        m = len(self.schur_dofs)
        if m == self.n and m:                                  # no interior (MUMPS asks SIZE_SCHUR < N)
            K = sp.coo_matrix((self._data, (self._rows - 1, self._cols - 1)), shape=(self.n,) * 2).toarray()
            K = np.tril(K) + np.tril(K, -1).T
            try:
                with cholesky_threads(m):
                    L = la.cholesky(K[np.ix_(self.schur_dofs, self.schur_dofs)], lower=True, check_finite=False)
            except la.LinAlgError:
                raise MumpsError("the matrix is not positive definite") from None
            return L, Statistics("none", 0, 0, 0, 0.0, m)
        s = self._struc = self._instance()
        schur = np.zeros((m, m))
        if m:
            s.schur = schur.ctypes.data_as(_P_REAL)
        self._call(1)
        while True:
            try:
                self._call(2)
                break
            except MumpsError:
                if s.infog[0] not in (-8, -9) or s.icntl[13] > 2000:
                    raise
                s.icntl[13] = 2 * max(s.icntl[13], 20)         # ICNTL(14): more working space, as MUMPS asks
        if s.infog[11] > 0:                                    # INFOG(12): negative pivots (SYM = 1 goes on)
            raise MumpsError(f"the matrix is not positive definite ({s.infog[11]} negative pivots)")
        stats = Statistics(ordering=[k for k, v in ORDERINGS.items() if v == s.infog[6]][0] if s.infog[6] in
                           ORDERINGS.values() else str(s.infog[6]), factor_entries=_entries(s.infog[28]),
                           estimated_mb=s.infog[16], used_mb=s.infog[21], flops=s.rinfog[2], schur_size=m)
        log.info("MUMPS: %d dofs, Schur complement onto %d, %s ordering, %d factor entries, %d MB",
                 self.n, m, stats.ordering, stats.factor_entries, stats.used_mb)
        # symmetric matrices: MUMPS fills one triangle (by rows, as C reads it the upper one is empty); the lower
        # Cholesky factor L (S = L L^T) overwrites it in place
        try:
            with cholesky_threads(m):
                return la.cholesky(schur, lower=True, overwrite_a=True, check_finite=False) if m else schur, stats
        except la.LinAlgError:
            raise MumpsError("the Schur complement is not positive definite") from None

    def solve(self, b: np.ndarray) -> np.ndarray:
        """K^-1 b for b (n,) or (n, k)."""
        if len(self.schur_dofs) == self.n:
            x = np.zeros((self.n, np.reshape(b, (self.n, -1)).shape[1]))
            x[self.schur_dofs] = la.cho_solve((self.schur_factor(), True), np.reshape(b, (self.n, -1))[self.schur_dofs])
            return x.reshape(b.shape)
        if self._struc is None and self.schur_cholesky is not None and len(self.schur_dofs):
            return self._solve_by_interior(b)
        if self._struc is None or self.schur_cholesky is None:
            self.free()
            self.schur_cholesky, self.stats = self._factor()
        rhs = np.asfortranarray(np.reshape(b, (self.n, -1)), dtype=float).copy(order="F")
        s, m, k = self._struc, len(self.schur_dofs), rhs.shape[1]
        s.rhs, s.nrhs, s.lrhs = rhs.ctypes.data_as(_P_REAL), k, self.n
        if m == 0:
            s.icntl[25] = 0
            self._call(3)
            return rhs.reshape(b.shape)
        reduced = np.zeros((m, k), order="F")
        s.redrhs, s.lredrhs = reduced.ctypes.data_as(_P_REAL), m
        s.icntl[25] = 1                                        # ICNTL(26): reduction onto the Schur dofs
        self._call(3)
        reduced[:] = la.cho_solve((self.schur_cholesky, True), reduced, check_finite=False)
        s.icntl[25] = 2                                        # expansion from the Schur dofs' solution
        self._call(3)
        s.icntl[25] = 0
        return rhs.reshape(b.shape)

    def _solve_by_interior(self, b: np.ndarray) -> np.ndarray:
        """K^-1 b from the kept Cholesky factor L of S and MUMPS's factor of K_ii alone (made at the first call,
        kept): x_s = S^-1 (b_s - K_si K_ii^-1 b_i), x_i = K_ii^-1 (b_i - K_is x_s); one interior solve where b_i is
        zero (the contact forces' right-hand sides)."""
        s = self.schur_dofs
        if self._interior is None:
            K = sp.coo_matrix((self._data, (self._rows - 1, self._cols - 1)), shape=(self.n,) * 2).tocsr()
            K = K + sp.triu(K.T, 1)                                          # the stored lower triangle, mirrored
            inner = np.setdiff1d(np.arange(self.n), s)
            self._interior = (SchurFactor(K[inner][:, inner], np.zeros(0, int), self.ordering), inner,
                              K[s][:, inner].tocsr())
        interior, inner, K_si = self._interior
        b2 = np.reshape(b, (self.n, -1))
        b_i = b2[inner]
        loaded = bool(np.any(b_i))
        y_s = b2[s] - K_si @ interior.solve(b_i) if loaded else b2[s]
        x = np.zeros(b2.shape)
        x[s] = la.cho_solve((self.schur_cholesky, True), y_s, check_finite=False)
        x[inner] = interior.solve(b_i - K_si.T @ x[s])
        return x.reshape(np.shape(b))

    def schur_factor(self) -> np.ndarray:
        """L (m, m) dense lower triangular, L L^T = S, in the order of ``schur``; factorised again if dropped."""
        if self.schur_cholesky is None:
            self.free()
            self.schur_cholesky, self.stats = self._factor()
        return self.schur_cholesky


@dataclass(frozen=True)
class Analysis:
    """What MUMPS's analysis (JOB = 1) predicts of a factorisation with a Schur complement, before it is made."""

    estimated_mb: int       # INFOG(17): estimated size [MB] of all MUMPS's internal data of the in-core factorisation
    factor_entries: int     # INFOG(20): estimated entries of the factor
    schur_size: int


def analyse(K: sp.spmatrix, schur: np.ndarray, ordering: str = "auto") -> Analysis:
    """MUMPS's analysis alone of the factorisation :class:`SchurFactor` would make of K (n, n) with the dofs
    ``schur`` last: the memory it will take, read before any numerical work (the analysis needs K's pattern only;
    its values must be those of a symmetric positive definite matrix with that pattern). Without interior dofs
    (``len(schur) == n``) no MUMPS factorisation is made: 0 MB."""
    factor = SchurFactor(K, schur, ordering, factorise=False)
    m = len(factor.schur_dofs)
    if m == factor.n:
        return Analysis(0, 0, m)
    try:
        s = factor._instance()
        factor._call(1)
        return Analysis(s.infog[16], _entries(s.infog[19]), m)
    finally:
        factor.free()


class BodySchur:
    """A :class:`SchurFactor` per body of a K (n, n) that has no coupling between its bodies (its connected
    parts), each onto that body's dofs among ``last``: the Schur complement onto ``last`` is block diagonal over
    the bodies, so the dense memory is the largest body's block squared.

    Attributes
    ----------
    last : (m,) indices into K's rows
    blocks : per body, the indices into ``last`` of its Schur dofs (in the order of ``last``)
    """

    def __init__(self, K: sp.spmatrix, last: np.ndarray, ordering: str | None = None):
        K = sp.csr_matrix(K)
        self.n = K.shape[0]
        self.last = np.asarray(last, dtype=int)
        _, body = connected_components(K, directed=False)
        position = np.full(self.n, -1)
        position[self.last] = np.arange(len(self.last))
        self.dofs, self.blocks, self.factors = [], [], []
        for b in range(body.max() + 1 if self.n else 0):
            dofs = np.flatnonzero(body == b)
            local = np.flatnonzero(position[dofs] >= 0)
            local = local[np.argsort(position[dofs[local]])]
            self.dofs.append(dofs)
            self.blocks.append(position[dofs[local]])
            self.factors.append(SchurFactor(K[dofs][:, dofs], local, ordering or ORDERING))

    def solve(self, b: np.ndarray) -> np.ndarray:
        """K^-1 b for b (n,) or (n, k)."""
        out = np.zeros(b.shape)
        for dofs, factor in zip(self.dofs, self.factors):
            out[dofs] = factor.solve(b[dofs])
        return out

    def free(self, schur: bool = True) -> None:
        """Release every body's MUMPS factor and with ``schur`` its Schur complement's factor; a later solve
        factorises again."""
        for factor in self.factors:
            factor.free(schur=schur)

    @property
    def stats(self) -> list[Statistics]:
        return [factor.stats for factor in self.factors]
