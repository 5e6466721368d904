"""Element functions as machine code where it pays: the ``compiled`` policy of an optimal-control problem.

An NLP of :mod:`.nlp_assembly` spends its evaluation time in a few SX functions (each element kind's
rows and cost, their Jacobian, the Lagrangian Hessian) mapped over their instances. CasADi's virtual
machine runs them at ~7 ns per operation; compiled to C by the system compiler (:mod:`..dynamics.compiled`,
cached on disk by the function's content, checked against the virtual machine before it is kept) they
run 3-20x faster. A UR5 arm's Lagrangian Hessian at a collocation point has 70,855 operations; its
Jacobian 19,966: at 200 points the virtual machine spends ~130 ms on them per IPOPT iteration
(``python scripts/compiled_elements_calibration.py``, which measures every constant below).

Compiling costs seconds, so the ``"auto"`` policy compiles a function when the time compiling it
saves is predicted to exceed its compile time, from its operation count ``n``, its instances ``K``
and the evaluations an IPOPT solve typically makes (:data:`EVALUATIONS`):

    saving  = n K E (VM_NS - COMPILED_NS[flags]) 1e-9 s,   compile = n COMPILE_S[flags] s

(:class:`Size`; the function alone is compiled: the NLP's derivatives are the assembled ones of
:mod:`.nlp_assembly`, and nlpsol is told not to differentiate the NLP's graph itself,
:attr:`.nlp_assembly.BlockNLP.derivative_options`), counting the savings the earlier solves of the same
problem would have had (their meshes' ``K``) with this one's: the rule of ski rental, rent (the virtual
machine) until the rent paid and due reaches the price (the compile), then buy; it never spends more
than twice the better of the two choices made in hindsight, and a refinement, whose meshes grow and
whose solves are many, compiles its heavy kinds after a few of them. ``-O1`` up to
:data:`O1_MAX_OPERATIONS` operations and ``-O0`` above (``-O1``'s compile time grows faster than the
function: 3.9 s at 20k operations, 44 s at 71k). A function compiled before (any problem, any run: the
cache is keyed by its content) is loaded whatever its size. Small problems (the swing-up: a few hundred
operations per kind) never compile.

Policies (``OptimalControlProblem.compiled``): ``"auto"`` (above), ``"always"`` (every function
now, or loaded), ``"never"`` (the virtual machine). Without a C compiler, or when it fails, the
virtual machine runs and a note says so once (:func:`..dynamics.compiled.compiled`).
"""
from __future__ import annotations

import hashlib
import sys
import time
from dataclasses import dataclass

import casadi as ca

from ..dynamics.compiled import FLAGS, FLAGS_QUICK, compiled, is_cached
from ..errors import ModelError

POLICIES = ("auto", "always", "never")
#: The virtual machine's time per operation (ns), and the compiled code's at -O1 / -O0.
VM_NS = 7.0
COMPILED_NS = {FLAGS: 0.6, FLAGS_QUICK: 2.0}
#: Compile time per operation (s) at -O1 (up to O1_MAX_OPERATIONS) and -O0.
COMPILE_S = {FLAGS: 2.0e-4, FLAGS_QUICK: 6.0e-5}
O1_MAX_OPERATIONS = 25_000
#: Below this predicted virtual-machine time in one solve (s) a function is left alone, not even looked up
#: in the cache (the lookup serializes it: ~0.1 ms for a small kind, on every mesh of a refinement).
MIN_VM_SECONDS = 0.2
#: Evaluations of each function in one IPOPT solve of ~25 iterations: the derivatives once an iteration,
#: the element kinds' rows and cost three times (objective, constraints, objective gradient's value).
EVALUATIONS = {"function": 75, "jac": 25, "grad": 25, "hess": 25}


def check_policy(policy: str) -> str:
    if policy not in POLICIES:
        raise ModelError(f"compiled must be one of {', '.join(POLICIES)}, got {policy!r}")
    return policy


@dataclass(frozen=True)
class Size:
    """What compiling one function involves: its operations and the flags (``-O1`` up to
    :data:`O1_MAX_OPERATIONS` operations, else ``-O0``). The function alone is compiled, without its
    Jacobian: nothing evaluates that (the NLP's derivatives are assembled, :mod:`.nlp_assembly`), and
    with it an element kind's rows cost several times their own compile (the UR5's point rows in joint
    coordinates: 3,242 operations, 23,245 with their Jacobian)."""

    operations: int
    flags: tuple[str, ...]

    @classmethod
    def of(cls, function: ca.Function) -> Size:
        n = function.n_instructions()
        return cls(n, FLAGS if n <= O1_MAX_OPERATIONS else FLAGS_QUICK)

    def saving(self, instances: int, evaluations: int) -> float:
        """Seconds the compiled copy saves over ``evaluations`` evaluations of ``instances`` instances."""
        return self.operations * instances * evaluations * (VM_NS - COMPILED_NS[self.flags]) * 1e-9

    @property
    def price(self) -> float:
        """Predicted compile time (s)."""
        return self.operations * COMPILE_S[self.flags]


@dataclass
class _Seen:
    """What a :class:`MachineCode` knows of one function: its size, content hash, the savings it missed, its copy."""

    function: ca.Function            # kept here, so its id is not reused while the record lives
    size: Size
    key: str
    missed: float = 0.0
    copy: ca.Function | None = None


class MachineCode:
    """The compiled copies of one problem's element functions, decided per function and kept for its later
    meshes and solves; ``seconds``: compile and load time spent by this object, ``compiled``: names compiled or loaded."""

    def __init__(self, policy: str):
        self.policy = check_policy(policy)
        self._seen: dict[int, _Seen] = {}
        self.seconds = 0.0
        self.compiled: list[str] = []

    def __call__(self, function: ca.Function, instances: int, kind: str) -> ca.Function:
        """``function`` (an SX function evaluated ``instances`` times per NLP evaluation) or its compiled copy;
        ``kind``: ``"function"`` (an element kind's rows and cost), ``"jac"``, ``"grad"`` or ``"hess"``."""
        if self.policy == "never" or not function.is_a("SXFunction"):
            return function
        if self.policy == "auto" and function.n_instructions() * instances * EVALUATIONS[kind] * VM_NS * 1e-9 < MIN_VM_SECONDS:
            return function
        seen = self._seen.get(id(function))
        if seen is None or seen.function is not function:
            # The content hash once: serializing a UR5 point Hessian takes ~10 ms, and the lookup comes every mesh.
            seen = _Seen(function, Size.of(function), hashlib.sha256(function.serialize().encode()).hexdigest())
            self._seen[id(function)] = seen
        if seen.copy is not None:
            return seen.copy
        size = seen.size
        cached = is_cached(function, key=seen.key, flags=size.flags)
        due = size.saving(instances, EVALUATIONS[kind])
        if not (self.policy == "always" or cached or seen.missed + due > size.price):      # ski rental
            seen.missed += due
            return function
        started = time.perf_counter()
        if size.price >= 1.0 and not cached:        # a pause the user should know of
            print(f"note: compiling '{function.name()}' ({size.operations:,} operations, about {size.price:.0f} s) to machine "
                  f"code for this and later solves (OptimalControlProblem.compiled = 'never' turns this off)", file=sys.stderr)
        seen.copy = compiled(function, key=seen.key, flags=size.flags,
                             what=f"'{function.name()}' ({size.operations:,} operations)")
        self.seconds += time.perf_counter() - started
        if seen.copy is not function:
            self.compiled.append(function.name())
        return seen.copy


def machine_code(owner, policy: str) -> MachineCode:
    """The :class:`MachineCode` kept on ``owner`` (an optimal-control problem) for ``policy``."""
    store = owner.__dict__.setdefault("_machine_code", {})
    if policy not in store:
        store[policy] = MachineCode(policy)
    return store[policy]
