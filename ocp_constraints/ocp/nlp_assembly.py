"""A block-structured NLP whose derivatives are assembled from its blocks' own.

A transcribed optimal-control problem is a few kinds of small pieces repeated over a
mesh: the dynamics at each point, the defects of each interval. Each kind is an
:class:`Element`: one SX function ``(z, c) -> (rows, cost)`` of a few decision
variables ``z = w[indices]`` and constants ``c``, repeated over its instances. The
NLP's constraints are every instance's rows, its objective the sum of their costs.

Why not let CasADi differentiate the whole NLP: on one SX graph its exact Hessian costs
seconds to build for a few hundred intervals (star colouring of the whole graph), and on
an MX graph of mapped functions it is cheap to build but several times slower to
evaluate (one directional sweep per colour). Here each element's Jacobian, cost
gradient and Lagrangian Hessian are taken once, symbolically, on the small function,
mapped over its instances, and scattered into the NLP's sparse matrices by one constant
sparse product. Build time grows like the mesh, evaluation is as fast as the inlined SX.
The result feeds ``casadi.nlpsol``'s ``grad_f``, ``jac_g`` and ``hess_lag`` options.

An element's symbolic derivatives depend on its function alone (the mesh enters through
instance counts, indices and constants), so a :func:`derivative_cache` keeps them per problem,
keyed by the function's own serialization: the meshes of one refinement, and repeat solves,
differentiate each kind once, and a problem edited after a solve (another objective, a path
constraint) has other functions, hence other keys: an edit can never meet a stale derivative.
"""
from __future__ import annotations

from dataclasses import dataclass

import casadi as ca
import numpy as np


@dataclass
class Element:
    """One kind of piece: ``function(z, c) -> (rows, cost)`` at every instance.

    ``indices[k]`` are the positions in the decision vector of instance ``k``'s ``z``
    (``-1``: a fixed zero); ``constants[k]`` its ``c``; ``lower``/``upper`` bound its
    rows (one value per row of one instance, or per row of every instance).
    """

    name: str
    function: ca.Function
    indices: np.ndarray
    constants: np.ndarray
    lower: np.ndarray
    upper: np.ndarray

    @property
    def instances(self) -> int:
        return self.indices.shape[0]

    @property
    def rows_per_instance(self) -> int:
        return self.function.size1_out(0)


def element(name: str, z: ca.SX, c: ca.SX, rows: ca.SX, cost, indices, constants, lower=0.0, upper=0.0) -> Element:
    """An :class:`Element` from SX expressions of ``z`` and ``c``; bounds default to equalities."""
    indices = np.atleast_2d(np.asarray(indices, dtype=np.int64))
    constants = np.asarray(constants, dtype=float).reshape(indices.shape[0], c.numel())
    if indices.shape[1] != z.numel():
        raise ValueError(f"element '{name}': {indices.shape[1]} indices for {z.numel()} variables")
    rows = ca.SX(rows) if not isinstance(rows, ca.SX) else rows
    f = ca.Function(name, [z, c], [ca.vec(rows), ca.SX(cost) if not isinstance(cost, ca.SX) else cost])
    return instances(name, f, indices, constants, lower, upper)


def instances(name: str, function: ca.Function, indices, constants, lower=0.0, upper=0.0) -> Element:
    """An :class:`Element` of a built ``function(z, c) -> (rows, cost)`` (one kind, reused across meshes)."""
    indices = np.atleast_2d(np.asarray(indices, dtype=np.int64))
    constants = np.asarray(constants, dtype=float).reshape(indices.shape[0], function.numel_in(1))
    if indices.shape[1] != function.numel_in(0):
        raise ValueError(f"element '{name}': {indices.shape[1]} indices for {function.numel_in(0)} variables")
    n = function.size1_out(0)
    lo = np.broadcast_to(np.asarray(lower, dtype=float), (n,) if np.size(lower) in (1, n) else (indices.shape[0] * n,))
    hi = np.broadcast_to(np.asarray(upper, dtype=float), lo.shape)
    return Element(name, function, indices, constants, np.array(lo, float), np.array(hi, float))


# Kinds kept per problem at most: a refinement meets ~10 (a point, the ends, an interval per degree);
# past this (a problem edited many times) the oldest go first.
CACHED_KINDS = 64


def derivative_cache(owner) -> dict:
    """The cache of element derivatives kept on ``owner`` (an optimal-control problem): serialized
    function -> its derivative functions (:meth:`BlockNLP._derivatives`)."""
    return owner.__dict__.setdefault("_element_derivatives", {})


class BlockNLP:
    """The NLP of a list of elements over ``n`` decision variables, with assembled derivatives;
    ``cache`` (:func:`derivative_cache`): element derivatives taken before, by function; ``machine_code``:
    ``(function, instances, kind) -> function to evaluate`` (a :class:`.compiled_elements.MachineCode`), else
    every function runs on CasADi's virtual machine."""

    def __init__(self, n: int, elements: list[Element], cache: dict | None = None, machine_code=None):
        self.n, self.elements, self._cache = n, elements, cache
        # Each function as it is evaluated: itself (CasADi's virtual machine) or its compiled copy (.compiled_elements).
        self._evaluated = machine_code or (lambda function, instances, kind: function)
        self.w = ca.MX.sym("w", n)
        self.lam_f, self.p = ca.MX.sym("lam_f"), ca.MX.sym("p", 0)
        w_ext = ca.vertcat(self.w, 0)  # index -1 (taken as n) reads a fixed zero
        self.row_offsets, offset = {}, 0
        for el in elements:
            self.row_offsets[el.name] = offset
            offset += el.instances * el.rows_per_instance
        self.m = offset
        self.lam_g = ca.MX.sym("lam_g", self.m)

        g, f, lbg, ubg = [], 0, [], []
        jac, grad, hess = _Entries(), _Entries(), _Entries()
        for el in elements:
            K, nr = el.instances, el.rows_per_instance
            Z = ca.reshape(w_ext[np.where(el.indices < 0, n, el.indices).ravel().tolist()], el.indices.shape[1], K)
            C = ca.DM(el.constants.T)
            rows, cost = self._evaluated(el.function, K, "function").map(K)(Z, C)
            g.append(ca.vec(rows))
            f += ca.sum2(cost)
            reps = K if el.lower.size == nr else 1
            lbg.append(np.tile(el.lower, reps))
            ubg.append(np.tile(el.upper, reps))
            self._differentiate(el, Z, C, jac, grad, hess)
        self.g = ca.vertcat(*g)
        self.f = f if isinstance(f, ca.MX) else ca.MX(0)
        self.lbg, self.ubg = np.concatenate(lbg), np.concatenate(ubg)
        self.grad_f = ca.Function("nlp_grad_f", [self.w, self.p], [self.f, ca.densify(grad.matrix(n, 1))],
                                  ["x", "p"], ["f", "grad_f_x"])
        self.jac_g = ca.Function("nlp_jac_g", [self.w, self.p], [self.g, jac.matrix(self.m, n)], ["x", "p"], ["g", "jac_g_x"])
        self.hess_lag = ca.Function("nlp_hess_l", [self.w, self.p, self.lam_f, self.lam_g], [hess.matrix(n, n)],
                                    ["x", "p", "lam_f", "lam_g"], ["triu_hess_gamma_x_x"])

    def _differentiate(self, el: Element, Z, C, jac: _Entries, grad: _Entries, hess: _Entries) -> None:
        """One element's Jacobian, cost gradient and Lagrangian Hessian (upper triangle), taken
        once on its SX function (or found in the cache), mapped over its instances, with their global positions."""
        K, nr, offset = el.instances, el.rows_per_instance, self.row_offsets[el.name]
        d = self._derivatives(el)
        if d["jac"] is not None:
            f, jr, jc = d["jac"]
            f = self._evaluated(f, K, "jac")
            jac.add(ca.vec(f.map(K)(Z, C)), offset + np.arange(K)[:, None] * nr + jr[None, :], el.indices[:, jc])
        if d["grad"] is not None:
            f, gi = d["grad"]
            f = self._evaluated(f, K, "grad")
            grad.add(ca.vec(f.map(K)(Z, C)), el.indices[:, gi], np.zeros((K, len(gi)), int))
        if d["hess"] is not None:
            f, hr, hc = d["hess"]
            f = self._evaluated(f, K, "hess")
            Lam = ca.reshape(self.lam_g[offset : offset + K * nr], nr, K)
            a, b = el.indices[:, hr], el.indices[:, hc]
            # A variable read twice by one instance: its local off-diagonal pair lands on
            # the global diagonal, where the symmetric counterpart adds the same again.
            hess.add(ca.vec(f.map(K)(Z, C, Lam, self.lam_f)), np.minimum(a, b), np.maximum(a, b),
                     np.where((a == b) & (hr != hc)[None, :], 2.0, 1.0))

    def _derivatives(self, el: Element) -> dict:
        """The derivative functions of ``el.function`` (one instance) and their sparsity triplets:
        ``jac`` (rows, z), ``grad`` (cost, z), ``hess`` (lower triangle of the Lagrangian's, with inputs
        z, c, row multipliers, cost multiplier); None where structurally zero. Cached by the function's
        serialization, which fixes the function completely (equal keys: the same function); a function
        object met before (an element kind kept by the transcription) is found by identity, unserialized."""
        if self._cache is None:
            key = None
        else:
            seen = self._cache.get(("object", id(el.function)))
            if seen is not None and seen[0] is el.function:
                return seen[1]
            key = el.function.serialize()
            if key in self._cache:
                self._remember(el.function, self._cache[key])
                return self._cache[key]
        nr = el.rows_per_instance
        z, c = ca.SX.sym("z", el.function.sparsity_in(0)), ca.SX.sym("c", el.function.sparsity_in(1))
        lam, lam_f = ca.SX.sym("lam", nr), ca.SX.sym("lam_f")
        rows, cost = el.function(z, c)

        def function(name: str, expr: ca.SX, inputs: list) -> ca.Function:
            return ca.Function(f"{el.name}_{name}", inputs, [expr.nz[:]])

        out = {"jac": None, "grad": None, "hess": None}
        J = ca.jacobian(rows, z)
        if J.nnz():
            out["jac"] = (function("jac", J, [z, c]), *(np.asarray(a) for a in J.sparsity().get_triplet()))
        gradient = ca.gradient(cost, z)
        if gradient.nnz():
            out["grad"] = (function("grad", gradient, [z, c]), np.asarray(gradient.sparsity().get_triplet()[0]))
        H = ca.tril(ca.hessian(lam_f * cost + ca.dot(lam, rows), z)[0])
        if H.nnz():
            out["hess"] = (function("hess", H, [z, c, lam, lam_f]), *(np.asarray(a) for a in H.sparsity().get_triplet()))
        if key is not None:
            while len(self._cache) >= 2 * CACHED_KINDS:
                del self._cache[next(iter(self._cache))]
            self._cache[key] = out
            self._remember(el.function, out)
        return out

    def _remember(self, function: ca.Function, derivatives: dict) -> None:
        # The function is kept with its entry, so its id is not reused while the entry lives.
        self._cache[("object", id(function))] = (function, derivatives)

    @property
    def nlp(self) -> dict:
        return {"x": self.w, "f": self.f, "g": self.g}

    @property
    def derivative_options(self) -> dict:
        """The ``nlpsol`` options that hand IPOPT the assembled derivatives, and keep nlpsol from
        differentiating the NLP's graph itself: by default it builds the Lagrangian's gradient
        (``nlp_grad``) at setup, for ``lam_p``; this NLP has no parameters and IPOPT returns ``lam_x``, so
        nothing evaluates it, yet building it took ~1 ms per NLP (swing-up, 207 points) and needed every
        compiled element function to carry its Jacobian (:mod:`.compiled_elements`)."""
        return {"grad_f": self.grad_f, "jac_g": self.jac_g, "hess_lag": self.hess_lag,
                "no_nlp_grad": True, "calc_lam_p": False}

    def rows(self, name: str, instance: int = 0) -> int:
        """First constraint row of ``instance`` of element ``name``."""
        el = next(e for e in self.elements if e.name == name)
        return self.row_offsets[name] + instance * el.rows_per_instance


class _Entries:
    """A sparse matrix gathered piece by piece: the sum of ``weight * source`` at ``(row, col)``.

    Entries touching a fixed zero (index -1) are dropped; repeated positions add up
    (a point shared by two intervals gets both intervals' Hessians).
    """

    def __init__(self):
        self.sources, self.rows, self.cols, self.weights = [], [], [], []

    def add(self, source: ca.MX, rows, cols, weights=None) -> None:
        rows = np.asarray(rows).ravel()
        self.sources.append(source)
        self.rows.append(rows)
        self.cols.append(np.asarray(cols).ravel())
        self.weights.append(np.ones(len(rows)) if weights is None else np.asarray(weights, float).ravel())

    def matrix(self, nrow: int, ncol: int) -> ca.MX:
        """The matrix as one MX: each position's first source entry gathered (``nz``), the repeated
        ones added by a sparse product over those entries alone.

        Why not one sparse product over every entry (as before): for a mesh of a refinement its
        sparse pattern and product cost ~3.5 ms of a ~15 ms build (swing-up, 232 points), where the
        Jacobian has no repeated position and the gather costs 0.3 ms; the patterns are built in
        compressed-column form from the sorted positions, not through ``Sparsity.triplet``'s sort."""
        if not self.sources:
            return ca.MX(nrow, ncol)
        r, c, scale = np.concatenate(self.rows), np.concatenate(self.cols), np.concatenate(self.weights)
        keep = np.flatnonzero((r >= 0) & (c >= 0))
        unique, first, position = np.unique(c[keep] * nrow + r[keep], return_index=True, return_inverse=True)
        counts = np.bincount(unique // nrow, minlength=ncol)
        sparsity = ca.Sparsity(nrow, ncol, np.concatenate([[0], np.cumsum(counts)]).tolist(), (unique % nrow).tolist())
        # Dense: a source may have structural zeros (a constant derivative), and the gather reads by position.
        sources = ca.densify(ca.vertcat(*self.sources))
        # Values in CCS order (positions sorted column-major): the first entry of each, weighted.
        values = sources.nz[keep[first].tolist()]
        if np.any(scale[keep[first]] != 1.0):
            values = values * ca.DM(scale[keep[first]])
        repeated = np.ones(len(keep), bool)
        repeated[first] = False
        if repeated.any():
            extra, at = keep[repeated], position.ravel()[repeated]
            # One entry per column (source), at the row of its position.
            colind = np.zeros(len(r) + 1, np.int64)
            colind[extra + 1] = 1
            order = np.argsort(extra)
            add = ca.DM(ca.Sparsity(len(unique), len(r), np.cumsum(colind).tolist(), at[order].tolist()), scale[extra[order]])
            values = values + ca.mtimes(add, sources)
        return ca.MX(sparsity, values)
