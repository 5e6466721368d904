"""The transcription's NLP as element kinds repeated over the mesh (:mod:`.nlp_assembly`), each kind built once.

A kind (the dynamics at a point, the defects of an interval of degree ``d``, the boundary rows) is an SX
function ``(z, c) -> (rows, cost)`` whose mesh enters only through the constants ``c`` (fractions,
quadrature weights, ``h``): the meshes of a refinement (:mod:`.mesh_refinement`), and repeat solves of
one problem, share it. Kinds are kept on the problem, keyed by what they are built from: the class of
the transcription, the kind and its local scheme, and the *fingerprint* of the problem's point functions
(their serialization: dynamics, constraints, objective integrand, path constraints, boundary
quantities, in the coordinates of the NLP), with the few numbers baked in besides (the final-time
weight, whether the final time is free). An edit of the problem after a solve changes the point
functions, so the fingerprint, so the key: it is never met by a stale kind.

The NLP itself (rows, variables, Posa slacks) is described in :mod:`.transcription`.
"""
from __future__ import annotations

from types import SimpleNamespace

import casadi as ca
import numpy as np

from ..errors import ModelError
from .free_mesh_points import check_free_points, link_row, phase_lengths, phase_of_intervals, phase_of_points
from .nlp_assembly import CACHED_KINDS, instances

SX = ca.SX


class ElementKinds:
    """The element methods of :class:`~.transcription.Transcription` (a mixin: it reads ``problem``, ``eqs``,
    ``layout``, ``scheme``, ``local``, ``offsets``, ``fractions``, ``quadrature``, ``from_speeds``)."""

    # Whether the NLP adds a free row of each bounded angle's rate (the maximal form; a joint view has its own rows).
    rate_rows = True

    @property
    def nlp_path_constraints(self) -> list:
        """The NLP's path rows: the problem's (a joint-coordinate view's hold its state bounds and their rates), and in
        the maximal form a free row of each bounded coordinate's rate where it is no single speed (an Euler angle's),
        and of each path constraint of the coordinates alone (:func:`of_coordinates`), which a refinement holds at zero
        at an arc's entry (:mod:`.imposed_arcs`)."""
        kept = self.__dict__.get("_nlp_path")
        if kept is None:
            pr, rows = self.problem, list(self.problem.path_constraints)
            if self.rate_rows:
                names = pr.model.coordinate_names
                rows += [free_rate_row(n, pr.quantity(f"{n}_dot"))
                         for n in pr.bounds if n in names and single_speed(pr.eqs, names.index(n)) is None]
                rows += [free_rate_row(c.label, path_rate(pr, c)) for c in pr.path_constraints if of_coordinates(pr, c)]
            kept = self.__dict__["_nlp_path"] = rows
        return kept

    def _groups(self) -> dict:
        """Intervals sharing one local scheme (one element kind each): ``{label: (scheme, [k, ...])}``."""
        out: dict = {}
        for k, local in enumerate(self.local):
            out.setdefault(local.label, (local, []))[1].append(k)
        return out

    def _kind(self, s, key: tuple, build) -> ca.Function:
        """The kind ``key`` from the problem's store, built by ``build()`` (-> ``(z, c, rows, cost)``) if missing."""
        owner = getattr(self, "user_problem", self.problem)
        store = owner.__dict__.setdefault("_element_kinds", {})
        full = (type(self).__qualname__, s.fingerprint, self.layout.free_time, *key)
        if full not in store:
            z, c, rows, cost = build()
            rows = rows if isinstance(rows, SX) else SX(rows)
            while len(store) >= CACHED_KINDS:
                del store[next(iter(store))]
            store[full] = ca.Function(str(key[0]), [z, c], [ca.vec(rows), cost if isinstance(cost, SX) else SX(cost)])
        return store[full]

    # -- the NLP as elements repeated over the mesh (see nlp_assembly) --------------------------
    def _indices(self) -> dict:
        """Where each point's blocks sit in the decision vector (``-1``: a fixed zero)."""
        lay = self.layout
        start = np.concatenate([[0], np.cumsum(lay.sizes())])

        # Each takes a point or an array of points (shape (..., 1)) and gives (..., size): the elements'
        # indices are built for all their instances at once.
        def block(b: int, size: int):
            return lambda i: start[b] + np.asarray(i) * size + np.arange(size)

        def gamma(i) -> np.ndarray:
            # No kinematic slack at t0: the positions there are the initial ones.
            i = np.asarray(i)
            return np.where(i > 0, start[4] + (i - 1) * lay.nh + np.arange(lay.nh), -1)

        return {"x": block(0, lay.nx), "a": block(1, lay.nu), "lam": block(2, lay.nc), "w": block(3, lay.n_in),
                "gamma": gamma, "T": [start[5]] if lay.free_time else [], "phases": start[6]}

    def _elements(self) -> list:
        """The NLP's pieces: dynamics at the points, defects on the intervals, t0 and end rows."""
        e, lay = self.eqs, self.layout
        T = SX.sym("T")
        # The point functions and their fingerprint, built once per refinement: the meshes of one
        # refinement (``_like``, see Transcription) are of one problem, which nothing edits between them
        # (building and serializing them again cost ~2 ms a mesh on the swing-up).
        like = getattr(self, "_like", None)
        point, fingerprint = like.point_pieces if like is not None else (None, None)
        if point is None:
            point = self._point_functions()
            fingerprint = _fingerprint(point)
        self.point_pieces = (point, fingerprint)
        check_free_points(self, point)
        # The horizon: a variable of every element (free final time) or a constant. The points and intervals read
        # it as their phase's time scale where the mesh has free points (.free_mesh_points): a variable each.
        index, phased, varied = self._indices(), bool(lay.n_phases), lay.free_time or bool(lay.n_phases)
        s = SimpleNamespace(point=point, fingerprint=fingerprint, index=index, T=T, varied=varied,
                            x=SX.sym("x", lay.nx), a=SX.sym("a", e.nu), lam=SX.sym("lam", e.nc),
                            w=SX.sym("w", lay.n_in), none=SX.sym("none", 0),
                            T_z=[T] if lay.free_time else [], T_c=[] if lay.free_time else [T],
                            T_value=[] if lay.free_time else [self.problem.t_final],
                            P_z=[T] if varied else [], P_c=[] if varied else [T],
                            P_value=[] if varied else [self.problem.t_final])
        if phased:
            of_points = index["phases"] + phase_of_points(self)
            of_intervals = index["phases"] + phase_of_intervals(self.scheme)
            s.P_points = lambda i: of_points[np.asarray(i)][:, None]           # one index per instance: its phase's
            s.P_intervals = lambda k: of_intervals[np.asarray(k)][:, None]
        else:
            s.P_points = s.P_intervals = lambda _: index["T"]
        return [*self._point_elements(s), *self._interval_elements(s), *self._end_elements(s)]

    def _point_rows(self, s, a) -> tuple:
        """Dynamics, velocity, position and path rows, and the integrand, at a point (``a``: u' there)."""
        pr, x, lam, w = self.problem, s.x, s.lam, s.w
        frac, quad = SX.sym("frac"), SX.sym("quad")
        t = frac * s.T
        rows = list(s.point["residuals"](x, a, lam, w, t))
        if self.nlp_path_constraints:
            rows.append(s.point["path"](x, lam, w, t))
        cost = quad * s.T * s.point["integrand"](x, lam, w, t) if pr.integral_terms else SX(0)
        return frac, quad, ca.vertcat(*rows), cost

    def _point_elements(self, s) -> list:
        """Dynamics, velocity, position and path rows, and the integrand, at every point."""
        pr, e, lay, scheme = self.problem, self.eqs, self.layout, self.scheme
        x, a, lam, w, index = s.x, s.a, s.lam, s.w, s.index
        n_eq = e.nu + e.nc + lay.nh
        path_lo, path_hi = scaled_path_bounds(self.nlp_path_constraints)
        lo, hi = [0.0] * n_eq + path_lo, [0.0] * n_eq + path_hi

        def build_point():
            frac, quad, rows, cost = self._point_rows(s, a)
            return ca.vertcat(x, a, lam, w, *s.P_z), ca.vertcat(frac, quad, *s.P_c), rows, cost

        at = np.arange(1 if self.from_speeds else lay.n_points)[:, None]
        # Where each point's position rows are: element, instance, first row in it (the dynamics and
        # velocity rows come first; read by Transcription._fixed_length_rows).
        self.position_rows_at = {int(k): ("point", int(k), e.nu + e.nc) for k in at[:, 0]}
        out = [instances("point", self._kind(s, ("point", s.varied), build_point),
                         _columns(len(at), index["x"](at), index["a"](at), index["lam"](at), index["w"](at),
                                  s.P_points(at[:, 0])),
                         _columns(len(at), self.fractions[at], self.quadrature[at], s.P_value), lo, hi)]
        if not self.from_speeds:
            return out
        # After t0: a = u' from the interval's speeds, (sum_r C[r, j] u_r) / h; one element
        # kind per interval degree (the column C_j has p entries).
        mesh, groups = scheme.mesh_fractions, self._groups()
        for label, (local, intervals) in groups.items():
            p, C = len(local.tau), local.derivative_matrix

            def build_collocation(p=p):
                us = SX.sym("u_interval", e.nu, p)
                column, h = SX.sym("C_j", p), SX.sym("h")
                frac, quad, rows, cost = self._point_rows(s, us @ column / (h * s.T))
                return (ca.vertcat(x, lam, w, ca.vec(us), *s.P_z), ca.vertcat(frac, quad, column, h, *s.P_c), rows, cost)

            # Instances: interval k's collocation points j = 1 .. p-1 (point i), each reading all p speeds of k.
            ks = np.repeat(intervals, p - 1)
            js = np.tile(np.arange(1, p), len(intervals))
            i = (self.offsets[ks] + js)[:, None]
            speeds = index["x"]((self.offsets[ks][:, None] + np.arange(p))[:, :, None])[:, :, e.nq :]
            name = "collocation_point" if len(groups) == 1 else f"collocation_point_{label}"
            self.position_rows_at.update({int(point): (name, r, e.nu + e.nc) for r, point in enumerate(i[:, 0])})
            out.append(instances(
                name,
                self._kind(s, ("collocation_point", label, s.varied), build_collocation),
                _columns(len(i), index["x"](i), index["lam"](i), index["w"](i), speeds.reshape(len(i), -1),
                         s.P_points(i[:, 0])),
                _columns(len(i), self.fractions[i], self.quadrature[i], C[:, js].T, (mesh[ks + 1] - mesh[ks])[:, None],
                         s.P_value),
                lo, hi))
        return out

    def _interval_elements(self, s) -> list:
        """The scheme's defects on every interval (one element kind per interval degree)."""
        e, lay, scheme, index = self.eqs, self.layout, self.scheme, s.index
        mesh, groups = scheme.mesh_fractions, self._groups()
        out = []
        for label, (local, intervals) in groups.items():
            p = len(local.tau)

            def build(local=local, p=p):
                xs = [SX.sym(f"x{j}", lay.nx) for j in range(p)]
                accelerations = [SX.sym(f"a{j}", e.nu) for j in range(p)]
                gammas = [SX.sym(f"gamma{j}", lay.nh) for j in range(p)]
                fractions, h = SX.sym("frac", p), SX.sym("h")
                D = [ca.vertcat(s.point["kinematics"](xs[j], gammas[j], fractions[j] * s.T), accelerations[j]) for j in range(p)]
                defects = local.defects(xs, D, h * s.T)
                if self.from_speeds:
                    # The speed rows hold by construction of a; only the coordinate rows remain.
                    defects, accelerations = [d[: e.nq] for d in defects], []
                return (ca.vertcat(*xs, *accelerations, *gammas, *s.P_z), ca.vertcat(fractions, h, *s.P_c),
                        ca.vertcat(*defects), 0)

            ks = np.asarray(intervals)
            points = self.offsets[ks][:, None] + np.arange(p)          # K x p
            at = points[:, :, None]
            variables = _columns(len(ks), index["x"](at).reshape(len(ks), -1),
                                 *([] if self.from_speeds else [index["a"](at).reshape(len(ks), -1)]),
                                 index["gamma"](at).reshape(len(ks), -1), s.P_intervals(ks))
            out.append(instances("interval" if len(groups) == 1 else f"interval_{label}",
                                 self._kind(s, ("interval", label, self.from_speeds, s.varied), build),
                                 variables,
                                 _columns(len(ks), self.fractions[points], (mesh[ks + 1] - mesh[ks])[:, None], s.P_value)))
        return out

    def _end_elements(self, s) -> list:
        """Acceleration-level constraints at t0, Radau's input extrapolation, boundary values, final time."""
        pr, e, lay, scheme, index = self.problem, self.eqs, self.layout, self.scheme, s.index
        x, a, w, none = s.x, s.a, s.w, s.none

        def build_acceleration():
            d0 = ca.vertcat(s.point["kinematics"](x, SX.zeros(lay.nh), 0), a)
            return ca.vertcat(x, a, w), none, s.point["acceleration"](x, d0, w, 0), 0

        out = [instances("acceleration", self._kind(s, ("acceleration",), build_acceleration),
                         [np.concatenate([index["x"](0), index["a"](0), index["w"](0)])], np.zeros((1, 0)))]
        if not scheme.first_point_has_controls and lay.n_in and not ca.depends_on(ca.vertcat(ca.vec(e.G), e.e), e.inputs):
            # Radau never uses inputs at t0 in its defects: take the first interval's input
            # polynomial there, so that lambda_0 (from the acceleration constraint) is consistent.
            ell = self.local[0].start_extrapolation

            def build_extrapolation():
                ws = [SX.sym(f"w{j}", lay.n_in) for j in range(len(ell) + 1)]
                # One product with the weights as a DM, not numpy scalars times SX term by term (each goes
                # through numpy's ufunc dispatch: ~4 ms a kind at degree 9, built once per first-interval degree).
                return ca.vertcat(*ws), none, ws[0] - ca.horzcat(*ws[1:]) @ ca.DM(np.asarray(ell, float)), 0

            out.append(instances("extrapolation", self._kind(s, ("extrapolation", self.local[0].label), build_extrapolation),
                                 [np.concatenate([index["w"](j) for j in range(len(ell) + 1)])], np.zeros((1, 0))))
        for which, values in (("initial", pr.initial_values), ("final", pr.final_values)):
            i = 0 if which == "initial" else lay.n_points - 1

            def build_boundary(values=values):
                quantities = [s.point["named"][n](x, w) for n in values]
                return ca.vertcat(x, w), none, ca.vertcat(*quantities) if quantities else SX(0, 1), 0

            out.append(instances(which, self._kind(s, (which, tuple(values)), build_boundary),
                                 [np.concatenate([index["x"](i), index["w"](i)])], np.zeros((1, 0))))
        if pr.terminal_terms:
            # Mayer terms: a cost at the last point, of its state and inputs and the final time.
            last = lay.n_points - 1
            out.append(instances("terminal", self._kind(s, ("terminal",), lambda: (
                ca.vertcat(x, w, *s.T_z), ca.vertcat(*s.T_c), SX(0, 1), s.point["terminal"](x, w, s.T))),
                [np.concatenate([index["x"](last), index["w"](last), index["T"]])], [s.T_value]))
        if lay.n_phases:
            n = lay.n_phases
            out.append(instances("phases", self._kind(s, ("phases", n), lambda: link_row(s, n, lay.free_time)),
                                 [np.concatenate([index["phases"] + np.arange(n), index["T"]])],
                                 [np.concatenate([phase_lengths(scheme), s.T_value])]))
        if lay.free_time and pr.time_weight:
            out.append(instances("final_time", self._kind(s, ("final_time", float(pr.time_weight)),
                                                          lambda: (s.T, none, SX(0, 1), pr.time_weight * s.T)),
                                 [index["T"]], np.zeros((1, 0))))
        return out

    # -- per-point pieces, as SX functions -----------------------------------------------------
    def _point_functions(self) -> dict:
        pr, e = self.problem, self.eqs
        x = ca.vertcat(e.q, e.u)
        d = SX.sym("d", x.numel())
        a = SX.sym("a", e.nu)
        # Position rows: the constraints' position forms and each unit quaternion's length (SystemEquations).
        positions = e.position_rows
        gam = SX.sym("gamma", positions.numel())
        lam = pr.lam
        phi_q = ca.jacobian(positions, e.q)
        kin = e.qdot + (phi_q.T @ gam if positions.numel() else 0)
        dyn = e.mass_matrix @ a - e.forces - e.G.T @ lam
        vel = e.G @ e.u + e.e
        out = {"kinematics": ca.Function("kinematics", [x, gam, e.t], [kin]),
               "residuals": ca.Function("residuals", [x, a, lam, e.inputs, e.t], [dyn, vel, positions])}
        pi = e.G @ e.u + e.e
        # d(pi)/dt at t0 with q' = D_q, u' = D_u; rows where an input enters are left out
        # (the input's rate there is the optimizer's free choice).
        acc = e.G @ d[e.nq :] + ca.jtimes(pi, e.q, d[: e.nq]) + ca.jacobian(pi, e.t)
        keep = [k for k in range(e.nc) if not ca.depends_on(pi[k], e.inputs)]
        out["acceleration"] = ca.Function("acceleration", [x, d, e.inputs, e.t], [acc[keep] if keep else SX(0, 1)])
        if pr.integral_terms:
            integrand = sum(term.weight * term.expression for term in pr.integral_terms)
            out["integrand"] = ca.Function("integrand", [x, lam, e.inputs, e.t], [integrand])
        if self.nlp_path_constraints:
            out["path"] = ca.Function("path", [x, lam, e.inputs, e.t],
                                      [ca.vertcat(*[c.expression / path_scale(c) for c in self.nlp_path_constraints])])
        for term in pr.integral_terms + pr.terminal_terms + pr.path_constraints:
            extra = [s.name() for s in ca.symvar(term.expression) if not ca.depends_on(ca.vertcat(x, lam, e.inputs, e.t), s)]
            if extra:
                raise ModelError(f"'{term.label}' uses {extra}, which are not quantities of model '{pr.model.name}'")
        if pr.terminal_terms:
            out["terminal"] = ca.Function("terminal", [x, e.inputs, e.t],
                                          [sum(term.weight * term.expression for term in pr.terminal_terms)])
        out["named"] = {n: ca.Function("boundary", [x, e.inputs], [pr.quantity(n)]) for n in {**pr.initial_values, **pr.final_values}}
        return out


def path_scale(constraint) -> float:
    """The divisor of a path constraint's NLP row and bounds: its largest finite bound's magnitude or its ``scale``
    (a friction cone's rows: the model's weight W and (mu W)^2), at least 1.

    A load bound in the user's units (``|F|^2 <= (515 N)^2``) puts rows of ~1e5 beside rows of ~1 in one
    NLP; IPOPT then crept at a small barrier parameter (a crane in minimum time under a rope-tension bound:
    230 iterations, 31 with the row divided by its bound; ``tests/test_ocp_user_problems.py``). Only the
    NLP's rows are scaled: values, violations and switches are evaluated from the expressions, in the
    user's units."""
    return max([1.0, float(constraint.scale)]
               + [abs(float(b)) for b in (constraint.lower, constraint.upper) if np.isfinite(b)])


def state_row(name: str) -> str:
    """The label of the path row that holds a bound on state ``name`` in joint coordinates (.joint_transcription)."""
    return f"bound on {name}"


def rate_row(name: str) -> str:
    """The label of the free path row of bounded coordinate ``name``'s rate (.joint_transcription, and
    :attr:`ElementKinds.nlp_path_constraints` in the maximal form)."""
    return f"rate of {name}"


def free_rate_row(name: str, rate) -> SimpleNamespace:
    """A free path row (no bounds) of coordinate ``name``'s ``rate``: a refinement holds it at zero at the entry of an
    arc on the coordinate's bound, which the coordinate reaches tangentially (.imposed_arcs)."""
    return SimpleNamespace(label=rate_row(name), expression=rate, lower=-np.inf, upper=np.inf, scale=1.0)


def of_coordinates(pr, constraint) -> bool:
    """Whether a path constraint is of the coordinates (and time) alone, no speed, input or multiplier in it: its
    second time derivative holds the accelerations (order two, like a coordinate's bound), and it reaches its bound
    tangentially, its rate zero there (.imposed_arcs)."""
    e, c = pr.eqs, constraint.expression
    others = ca.vertcat(e.u, e.inputs, pr.lam)
    return bool(ca.depends_on(c, e.q)) and not (others.numel() and ca.depends_on(c, others))


def path_rate(pr, constraint) -> ca.SX:
    """A path constraint's time derivative along the motion, ``dg/dq N(q) u + dg/dt`` (the bodies' kinematics ``q' = N(q)
    u``, :attr:`.SystemEquations.qdot`), in the problem's maximal coordinates."""
    e = pr.eqs
    return ca.jtimes(constraint.expression, e.q, e.qdot) + ca.jacobian(constraint.expression, e.t)


def single_speed(eqs, i: int) -> int | None:
    """The speed that coordinate ``i``'s rate is, where it is one speed alone (``q_i' = u_j``: a translation's in the
    maximal form), else None (an Euler angle's rate mixes the angular speeds)."""
    N = ca.jacobian(eqs.qdot[i], eqs.u)
    if not N.is_constant() or N.nnz() != 1:
        return None
    j = N.sparsity().get_col()[0]
    return j if float(ca.DM(N)[0, j]) == 1.0 else None


def scaled_path_bounds(constraints) -> tuple[list[float], list[float]]:
    """The path rows' lower and upper bounds as the NLP holds them, each divided by its :func:`path_scale`."""
    return ([c.lower / path_scale(c) for c in constraints], [c.upper / path_scale(c) for c in constraints])


def _columns(rows: int, *blocks) -> np.ndarray:
    """Blocks side by side, one row per instance: 2-D arrays of ``rows`` rows, or one row (a list: the final
    time's index or value) repeated on every row. Indices come out as floats, exact, cast back by the element."""
    return np.hstack([np.asarray(b) if np.ndim(b) == 2 else np.broadcast_to(np.asarray(b, float), (rows, len(b)))
                      for b in blocks])


def _fingerprint(point: dict) -> str:
    """What the point functions compute, as one string (their serializations, in a fixed order): two
    problems, or one before and after an edit, share element kinds only where these are equal."""
    named = point.get("named", {})
    parts = [f"{k}:{point[k].serialize()}" for k in sorted(point) if k != "named"]
    parts += [f"named {n}:{named[n].serialize()}" for n in sorted(named)]
    return "\n".join(parts)
