"""How much memory a condensation will take, and the refusal before it would take more than it may.

A condensation (:meth:`frictionid.fem.problem.Problem.build`: assembly of the stiffness, its sparse factor, the
dense blocks of the contact and observation dofs) grows faster than the dofs: about n^1.3 over the sizes
measured in 3-D, the factor's fill alone about n^1.5 (docs/solver.md). The law is anchored on the peak resident
memory of processes that built and condensed the 3-D block (hex8 with incompatible modes, CHOLMOD, METIS)
with observation points: 23,595 / 56,187 / 113,616 dofs: 0.49 / 1.36 / 3.6 GB (``benchmarks/tilt_product.py``
at mesh 1.0 and 0.7; ``frictionid identify`` with ``refine_target = 1`` on tests/fixtures/independent_block,
whose estimate condensed mesh 0.5; measured 2026-11-26 with /usr/bin/time), times :data:`SAFETY`; in 2-D on the
plane-strain block's condensation (52,374 dofs: 0.37 GB, docs/solver.md) doubled for its assembly. SuperLU (the
fallback) took about three times CHOLMOD's.

The dense contact blocks come on top (:func:`contact_bytes`): with n_w = dim n_c contact dofs the condensation
holds the condensed operator W (n_w^2), the Schur complement's per-body factor and its triangular solves (about
n_w^2 each for a two-body interface): about 4 n_w^2 doubles at its peak (benchmarks/contact_dense.py); a solve
then holds W, the stuck Jacobian's inverse (fem/updated_jacobian.py), the kept capacitance factorisations and
A's block of their rows: measured 4.9 n_w^2 doubles in the first solve and 5.0 over two on the half-space
interface at n_w 9,000 in gross slip (``benchmarks/contact_loadpath.py 9000 --solves 2``, the process's peak, W
included). :data:`CONTACT_WORDS` n_w^2 doubles is the larger. The block's anchors have a few hundred contact
pairs, where this is negligible; the 3-D bolt's thread has thousands, where it dominates (5,777 pairs, 17,331
contact dofs: 11.2 GB).
Above :data:`frictionid.fem.condense_implicit.IMPLICIT_ABOVE` contact dofs the condensation never forms them
(fem/condense_implicit.py); the load path's penalised factor (fem/contact_krylov.py) comes on top instead,
counted as a second factorisation of the stiffness.

With ``factorisation = "mumps"`` the condensation's part is not this law (fitted on CHOLMOD's factor with the
contact dofs last, which a multifrontal factor of the interior does not have: 23.6 GB estimated, with 4 n_w^2
contact words, for the short 3-D bolt that peaked at 8.3 GiB) but MUMPS's own analysis of the model's bodies, the
space and copies of K beside it and the dense contact blocks of the first solve, phase by phase
(fem/mumps_memory.py).

``[solver] max_memory`` [GB] is what a run may take; default :data:`DEFAULT_FRACTION` of the machine's memory.

The law misses what it was not anchored on: a dense DIC grid's observation rows (thousands of observed dofs in
the dense trailing blocks of the factor) and refinements in one direction only (the footprint of the 3-D block:
its fill grows faster than n^1.3). Measured on tests/fixtures/dense_block (all observations, 2 mm window), the
law against the peak of the build (``/usr/bin/time``): 0.81 / 0.95 GB (block as given, 7,865 nodes), 1.52 / 1.79
(layers x 2), 2.30 / 3.38 (footprint x 2: 47 % under), 3.25 / 3.31 (layers x 4). Where a run builds models before
it chooses one (the discretisation control), :class:`Peak` measures what each build took and
:func:`estimate`'s ``scale`` carries the largest ratio of measured to estimated to the models it has not built.
"""

from __future__ import annotations

import os
import resource
from dataclasses import dataclass, field

from ..errors import InputError

GB = 1024.0 ** 3
#: the default of ``[solver] max_memory``: this fraction of the machine's physical memory
DEFAULT_FRACTION = 0.5
#: (dofs, peak above the process before [bytes], exponent) anchoring the law per dimension (module docstring)
LAWS = {3: (113_616, 3.6 * GB, 1.3), 2: (52_374, 0.74 * GB, 1.2)}
#: margin on the measured laws (their scatter against the measurements: -13 % to +3 %)
SAFETY = 1.25
#: SuperLU against CHOLMOD (docs/solver.md: 4.0 against 1.9 GB at 114k dofs with the process's own)
SUPERLU_FACTOR = 3.0
#: dense (n_w, n_w) arrays of doubles held at once by a condensation or a solve, the larger (module docstring)
CONTACT_WORDS = 5


def machine_memory() -> float:
    """Physical memory of the machine [bytes]."""
    return float(os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES"))


def resident() -> float:
    """This process's resident memory now [bytes]: what it holds before a condensation (/proc/self/statm; the
    peak so far, Linux ru_maxrss in kB, where /proc is missing). Not the peak: a condensation that ran before and
    was freed (the discretisation control's refined models) would otherwise count as held (measured on the dense
    reference: peak 4.6 GB after one, 1.3 GB held during the fit that followed)."""
    try:
        with open("/proc/self/statm") as statm:
            return float(statm.read().split()[1]) * os.sysconf("SC_PAGE_SIZE")
    except (OSError, IndexError, ValueError):
        return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024.0


def _peak_resident() -> float | None:
    """The process's peak resident memory since it started or since the last :func:`_reset_peak` [bytes]
    (VmHWM of /proc/self/status); None where /proc is missing."""
    try:
        with open("/proc/self/status") as status:
            for line in status:
                if line.startswith("VmHWM:"):
                    return float(line.split()[1]) * 1024.0
    except (OSError, IndexError, ValueError):
        pass
    return None


#: [bytes] the largest peak of this process before :func:`_reset_peak` started it anew (:func:`process_peak`)
_peak_before_reset = 0.0


def process_peak() -> float:
    """This process's peak resident memory since it started [bytes], across the resets of :class:`Peak` (which
    start the kernel's own peak, ``ru_maxrss`` and ``/usr/bin/time``'s "Maximum resident set size", anew)."""
    now = _peak_resident()
    if now is None:
        now = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024.0
    return max(_peak_before_reset, now)


def _reset_peak() -> bool:
    """Start the peak anew (Linux: writing 5 to /proc/self/clear_refs resets VmHWM); False where it cannot."""
    global _peak_before_reset
    _peak_before_reset = process_peak()
    try:
        with open("/proc/self/clear_refs", "w") as refs:
            refs.write("5")
    except OSError:
        return False
    return True


@dataclass
class Peak:
    """The memory one piece of work took above what the process held before it [bytes], measured where Linux
    lets the peak be reset (``None`` elsewhere; the process's own peak is then :func:`process_peak`)::

        with Peak() as took:
            build()
        took.above   # bytes, or None
    """

    above: float | None = field(default=None, init=False)

    def __enter__(self) -> "Peak":
        self._held = resident()
        self._measured = _reset_peak()
        return self

    def __exit__(self, *exc) -> None:
        peak = _peak_resident() if self._measured else None
        self.above = None if peak is None else max(0.0, peak - self._held)


def limit(max_memory: float | None, where: str = "[solver]") -> float:
    """The memory a run may take [bytes]: ``max_memory`` [GB], or the default fraction of the machine's.

    Raises
    ------
    InputError
        For a ``max_memory`` that is not a positive number (``where`` names its table).
    """
    if max_memory is None:
        return DEFAULT_FRACTION * machine_memory()
    if isinstance(max_memory, bool) or not isinstance(max_memory, (int, float)) or not max_memory > 0:
        raise InputError(f"{where} max_memory must be a memory size [GB] > 0, got {max_memory!r}")
    return float(max_memory) * GB


def condensation_bytes(n_dofs: int, dim: int, factorisation: str = "cholmod") -> float:
    """Estimated peak of condensing a model of ``n_dofs`` dofs in ``dim`` dimensions, above what the process
    holds before [bytes] (module docstring).

    >>> round(condensation_bytes(113_616, 3) / GB, 2)
    4.5
    """
    dofs, peak, exponent = LAWS[3 if dim >= 3 else 2]
    grown = SAFETY * peak * (n_dofs / dofs) ** exponent
    return grown * (SUPERLU_FACTOR if factorisation == "superlu" else 1.0)


def contact_bytes(n_pairs: int, dim: int) -> float:
    """Estimated dense memory of the condensed contact operators for ``n_pairs`` contact pairs [bytes] (module
    docstring).

    >>> round(contact_bytes(5_777, 3) / GB, 1)
    11.2
    """
    return CONTACT_WORDS * 8.0 * (dim * n_pairs) ** 2


def contact_pairs(model) -> int:
    """Number of contact pairs of a model's interfaces before they are made: the nodes of their zones."""
    import numpy as np

    zones = [z for interface in model.interfaces for z in interface.zones]
    if not zones:
        return 0
    return sum(len(np.unique(np.concatenate([model.mesh.boundary(z).ravel() for z in interface.zones])))
               for interface in model.interfaces if interface.zones)


@dataclass(frozen=True)
class MemoryEstimate:
    """A condensation's estimated cost: the model's size and the memory it would reach against the limit."""

    what: str
    n_nodes: int
    n_dofs: int
    needed: float          # [bytes] the process's peak after it: what it holds plus the condensation's peak
    allowed: float         # [bytes]
    held: float = 0.0      # [bytes] what the process held when estimated (part of ``needed``)

    @property
    def above(self) -> float:
        """[bytes] the condensation's own estimated peak: ``needed`` less what the process held."""
        return self.needed - self.held

    @property
    def fits(self) -> bool:
        return self.needed <= self.allowed

    def line(self) -> str:
        return (f"{self.what}: {self.n_nodes:,} nodes, {self.n_dofs:,} dofs, estimated memory "
                f"{self.needed / GB:.1f} GB of {self.allowed / GB:.1f} GB allowed")


def estimate(model, what: str, max_memory: float | None = None, factorisation: str = "auto",
             n_nodes: int | None = None, scale: float = 1.0) -> MemoryEstimate:
    """The memory a condensation of ``model`` (with ``n_nodes`` nodes if given: a model not built yet) would
    reach in this process, against ``[solver] max_memory``; ``scale`` multiplies the condensation's part (the
    ratio of measured to estimated on builds of the same run: module docstring)."""
    from . import mumps_memory, mumps_schur
    from .cholesky import available

    grown = 1.0 if n_nodes is None else int(n_nodes) / model.mesh.n_nodes
    n_nodes = model.mesh.n_nodes if n_nodes is None else int(n_nodes)
    dim = 3 if model.kind == "3d" else 2                               # the mesh's dimension: the fill's law
    n_components = 3 if model.kind in ("3d", "axisymmetric_twist") else 2
    n_dofs = n_nodes * n_components
    if factorisation == "auto":
        factorisation = automatic(model, n_nodes)
    method = "mumps" if factorisation == "mumps" and mumps_schur.available() else \
        "superlu" if factorisation == "superlu" or not available() else "cholmod"
    # a refinement grows the interfaces' pairs by at most the nodes' factor to the power (dim - 1) / dim
    pairs = contact_pairs(model) * grown ** ((dim - 1) / dim)
    from .condense_implicit import IMPLICIT_ABOVE

    dense = n_components * pairs <= IMPLICIT_ABOVE
    if method == "mumps" and dense:      # the dense contact blocks are its solve's phase (fem/mumps_memory.py)
        above = mumps_memory.peak_bytes(model, pairs, grown)
    else:                                # the implicit path factorises K with CHOLMOD whatever it is asked for
        method = "cholmod" if method == "mumps" else method
        factored = condensation_bytes(n_dofs, dim, method)
        above = factored + (contact_bytes(int(pairs), n_components) if dense else factored)
    held = resident()
    return MemoryEstimate(what, n_nodes, n_dofs, held + scale * above, limit(max_memory), held)


def automatic(model, n_nodes: int | None = None) -> str:
    """What ``factorisation = "auto"`` condenses ``model`` (with ``n_nodes`` nodes if given) with: CHOLMOD where
    its estimate fits the default ``[solver] max_memory`` (the fastest where it fits), else MUMPS where it is
    installed and its estimate is the smaller (on the 3-D bolt about a third of CHOLMOD's); SuperLU without
    kvxopt."""
    from . import mumps_schur
    from .cholesky import available

    if not available():
        return "superlu"
    cholmod = estimate(model, "", None, "cholmod", n_nodes)
    if cholmod.fits or not mumps_schur.available():
        return "cholmod"
    return "mumps" if estimate(model, "", None, "mumps", n_nodes).needed < cholmod.needed else "cholmod"


def check(model, what: str, max_memory: float | None = None, factorisation: str = "auto",
          n_nodes: int | None = None) -> MemoryEstimate:
    """:func:`estimate`, refused with a message naming the cost when it exceeds the limit (nothing allocated yet).

    Raises
    ------
    InputError
        When the estimate exceeds ``[solver] max_memory`` (or its default).
    """
    cost = estimate(model, what, max_memory, factorisation, n_nodes)
    if not cost.fits:
        origin = "[solver] max_memory" if max_memory is not None else \
            f"the default [solver] max_memory ({DEFAULT_FRACTION:g} of this machine's {machine_memory() / GB:.1f} GB)"
        raise InputError(f"{cost.line()}: more than {origin} allows; refused before condensing it. Use a coarser "
                         "mesh, a lower identify.refine_budget or a higher identify.refine_target, or raise "
                         "[solver] max_memory [GB] if the machine has the memory")
    return cost


def check_growth(model, factor: int, what: str, max_memory: float | None = None) -> None:
    """Refuse, before its mesh is built, a refinement of ``model`` by ``factor`` whose condensation would exceed
    the limit even if its nodes grew only by ``factor^(dim - 1)`` (the least a refinement of the block's and the
    bolt's graded meshes grows by: their far field keeps its size; a uniform mesh grows by ``factor^dim``).

    Raises
    ------
    InputError
        As :func:`check`, naming the least size and memory the refined model would have.
    """
    dim = 3 if model.kind == "3d" else 2
    check(model, what + " (at least)", max_memory, n_nodes=model.mesh.n_nodes * factor ** (dim - 1))
