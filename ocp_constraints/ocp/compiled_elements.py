"""Element functions as machine code where it pays: the ``compiled`` policy of an optimal-control problem.

An NLP of :mod:`.nlp_assembly` spends its evaluation time in a few SX functions (each element kind's
rows, their Jacobian, the Lagrangian Hessian) mapped over their instances, most of it in the derivatives. CasADi's virtual machine runs
them at ~7 ns per operation; compiled to C by the system compiler (:mod:`..dynamics.compiled`, cached
on disk by the function's content) they run 5-18x faster. A UR5 arm's Lagrangian Hessian at a
collocation point has 70,855 operations: at 200 points the virtual machine spends 93 ms on it per
IPOPT iteration, the ``-O1`` library 5 ms and the ``-O0`` one 16 ms
(``python scripts/compiled_elements_calibration.py``, which measures every constant below).

Compiling costs seconds, so the ``"auto"`` policy compiles a function when the time compiling it
saves is predicted to exceed its compile time, from its operation count ``n``, its instances ``K``
and the evaluations an IPOPT solve typically makes (:data:`EVALUATIONS`):

    saving  = n K E (VM_NS - COMPILED_NS[flags]) 1e-9 s,   compile = n COMPILE_S[flags] s,

counting the savings the earlier solves of the same problem would have had (their meshes' ``K``)
with this one's: the rule of ski rental, rent (the virtual machine) until the rent paid and due
reaches the price (the compile), then buy; it never spends more than twice the better of the two
choices made in hindsight, and a refinement, whose meshes grow and whose solves are many, compiles
its heavy kinds after a few of them. ``-O1`` up to :data:`O1_MAX_OPERATIONS` operations and ``-O0``
above (``-O1``'s compile time grows faster than the function: 3.9 s at 20k operations, 44 s at 71k).
A function compiled before (any problem, any run: the cache is keyed by its content) is loaded
whatever its size. Small problems (the swing-up: a few hundred operations per kind) never compile.

Policies (``OptimalControlProblem.compiled``): ``"auto"`` (above), ``"always"`` (every function
now, or loaded), ``"never"`` (the virtual machine). Without a C compiler, or when it fails, the
virtual machine runs and a note says so once (:func:`..dynamics.compiled.compiled`).
"""
from __future__ import annotations

import hashlib
import sys
import time

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
#: Evaluations of each derivative function in one IPOPT solve of ~25 iterations (once an iteration). The
#: element kinds' rows and cost stay on the virtual machine (:class:`.nlp_assembly.BlockNLP`: nlpsol
#: differentiates them), 10-15% of the evaluation time (UR5, Radau 5 on 40 intervals).
EVALUATIONS = {"jac": 25, "grad": 25, "hess": 25}


def check_policy(policy: str) -> str:
    if policy not in POLICIES:
        raise ModelError(f"compiled must be one of {', '.join(POLICIES)}, got {policy!r}")
    return policy


def flags_for(function: ca.Function) -> tuple[str, ...]:
    """``-O1`` for a function of at most :data:`O1_MAX_OPERATIONS` operations, else ``-O0``."""
    return FLAGS if function.n_instructions() <= O1_MAX_OPERATIONS else FLAGS_QUICK


def saving(function: ca.Function, instances: int, evaluations: int) -> float:
    """Seconds the compiled ``function`` saves over ``evaluations`` evaluations of ``instances`` instances."""
    return function.n_instructions() * instances * evaluations * (VM_NS - COMPILED_NS[flags_for(function)]) * 1e-9


def pays(function: ca.Function, instances: int, evaluations: int, earlier: float = 0.0) -> bool:
    """Whether compiling ``function`` now is predicted to cost less than the virtual machine's extra time
    over ``evaluations`` evaluations of ``instances`` instances, plus ``earlier`` seconds the earlier solves
    would have saved (ski rental, see the module docstring)."""
    return earlier + saving(function, instances, evaluations) > function.n_instructions() * COMPILE_S[flags_for(function)]


class MachineCode:
    """The compiled copies of one problem's element functions, decided per function and kept for its later
    meshes and solves; ``seconds``: compile and load time spent by this object, ``compiled``: names compiled or loaded."""

    def __init__(self, policy: str):
        self.policy = check_policy(policy)
        self._done: dict[int, tuple[ca.Function, ca.Function]] = {}    # id(function) -> (function, its copy)
        self._rent: dict[int, tuple[ca.Function, float]] = {}            # id(function) -> (function, savings missed)
        self._keys: dict[int, tuple[ca.Function, str]] = {}              # id(function) -> (function, content hash)
        self.seconds = 0.0
        self.compiled: list[str] = []

    def __call__(self, function: ca.Function, instances: int, kind: str) -> ca.Function:
        """``function`` (an SX function evaluated ``instances`` times per NLP evaluation) or its compiled copy;
        ``kind``: ``"jac"``, ``"grad"`` or ``"hess"`` (:data:`EVALUATIONS`)."""
        if self.policy == "never" or not function.is_a("SXFunction"):
            return function
        if self.policy == "auto" and function.n_instructions() * instances * EVALUATIONS[kind] * VM_NS * 1e-9 < MIN_VM_SECONDS:
            return function
        seen = self._done.get(id(function))
        if seen is not None and seen[0] is function:
            return seen[1]
        flags, key = flags_for(function), self._key(function)
        if not (self.policy == "always" or is_cached(function, key=key, flags=flags)
                or pays(function, instances, EVALUATIONS[kind], self._missed(function))):
            rent = self._rent.get(id(function), (function, 0.0))[1]
            self._rent[id(function)] = (function, rent + saving(function, instances, EVALUATIONS[kind]))
            return function
        started = time.perf_counter()
        n = function.n_instructions()
        if n * COMPILE_S[flags] >= 1.0 and not is_cached(function, key=key, flags=flags):      # a pause the user should know of
            print(f"note: compiling '{function.name()}' ({n:,} operations, about {n * COMPILE_S[flags]:.0f} s) to machine "
                  f"code for this and later solves (OptimalControlProblem.compiled = 'never' turns this off)", file=sys.stderr)
        copy = compiled(function, key=key, flags=flags, what=f"'{function.name()}' ({function.n_instructions()} operations)")
        self.seconds += time.perf_counter() - started
        if copy is not function:
            self.compiled.append(function.name())
        self._done[id(function)] = (function, copy)    # the function is kept with it: its id is not reused
        return copy

    def _key(self, function: ca.Function) -> str:
        """The function's content hash, computed once (serializing a UR5 point Hessian takes ~10 ms, every mesh)."""
        seen = self._keys.get(id(function))
        if seen is None or seen[0] is not function:
            seen = (function, hashlib.sha256(function.serialize().encode()).hexdigest())
            self._keys[id(function)] = seen
        return seen[1]

    def _missed(self, function: ca.Function) -> float:
        """What compiling ``function`` would have saved in this problem's earlier solves (s)."""
        seen = self._rent.get(id(function))
        return seen[1] if seen is not None and seen[0] is function else 0.0


def machine_code(owner, policy: str) -> MachineCode:
    """The :class:`MachineCode` kept on ``owner`` (an optimal-control problem) for ``policy``."""
    store = owner.__dict__.setdefault("_machine_code", {})
    if policy not in store:
        store[policy] = MachineCode(policy)
    return store[policy]
