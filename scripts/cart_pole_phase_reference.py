"""The newcomer cart-pole (a hinge-force bound, one constrained arc) against a phase reference whose junction times
are its own decision variables, not the library's.

    python scripts/cart_pole_phase_reference.py [--tolerance 1e-5] [--per-phase 40 80 160] [--uniform 100]

1. A uniform solve in minimal coordinates (``npb.cart_pole_reference``: Lagrange's equations, plain CasADi Opti,
   Radau 7 on ``--uniform`` intervals) finds the arc structure: where ``|F|^2 = f_max^2`` is active.
2. The phase reference: the same minimal system, Radau 7 in three phases ``[0, t1]``, ``[t1, t2]``, ``[t2, T]``
   (``N`` uniform intervals each, ``t1``, ``t2`` decision variables, states continuous across the phases), the
   bound as an equality on the middle phase and as the inequality on the outer ones, at several resolutions
   (``--per-phase``); printed: their differences (states, hinge force relative to the largest load, ``t1``, ``t2``,
   objective), whether the outer phases' bound stays inactive and the arc's multipliers keep one sign.
3. The library's solution (``npb.cart_pole().solve(tolerance=...)``) against the finer phase reference, at the
   library's collocation points and midway between them (the library's own interpolation: states by
   ``sol.interpolate``, the hinge force from the interpolated coordinates, speeds and multipliers): largest errors
   and where, the library's located junctions against ``t1``, ``t2``.

The reference is evaluated between its points by each interval's collocation polynomials (states degree 7 through
the interval's 8 nodes, the push degree 6 through its 7 collocation points), the hinge force from those
(``npb.cart_pole_hinge_force``). A measurement, not a test; one solve at a time (~2 min for the library's).
"""
from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

import casadi as ca
import numpy as np

sys.path.insert(0, str(Path(__file__).parent))
import newcomer_problems as npb  # noqa: E402  (a script beside this one: the problem and its minimal system)

NAMES = ("cart.x", "pole.psi", "cart.vbar_x", "pole.omega_z")      # (q, qd) of the minimal system, in order
FORCE = ("hinge@pole.F_x", "hinge@pole.F_y", "hinge@pole.F_z")
P = npb.CARTPOLE
DEGREE = 7
TOL, STRICT = 1e-12, False


def _system():
    s = npb.cart_pole_system()
    x = ca.vertcat(s.q, s.qd)
    F = npb.cart_pole_hinge_force(s)
    return s, ca.Function("f", [x, s.w], [ca.vertcat(s.qd, s.qdd)]), ca.Function("F", [x, s.w], [F]), \
        ca.Function("F2", [x, s.w], [ca.sumsqr(F)])


# -- 1. the arc structure from a uniform solve ----------------------------------------------------------------
def arcs_of(t, g2, active=1e-6):
    """Maximal runs of points where ``|F|^2 >= f_max^2 (1 - active)``: ``[(first, last)]`` times."""
    on = g2 >= P["f_max"] ** 2 * (1.0 - active)
    runs, i = [], 0
    while i < len(on):
        if on[i]:
            j = i
            while j + 1 < len(on) and on[j + 1]:
                j += 1
            runs.append((t[i], t[j]))
            i = j + 1
        else:
            i += 1
    return runs


def uniform_solve(N: int) -> dict:
    s, _, F, F2 = _system()
    r = npb.cart_pole_reference(N, degree=DEGREE, guess=lambda u: np.vstack([0 * u, math.pi * u]))
    r["F"] = np.asarray(F.map(r["W"].shape[1])(r["X"][:, 1:], r["W"])).T           # at the collocation points
    r["F2"] = np.asarray(F2.map(r["W"].shape[1])(r["X"][:, 1:], r["W"])).ravel()
    return r


# -- 2. the phase reference -----------------------------------------------------------------------------------
class PhaseSolution:
    """Radau-``DEGREE`` solution on three phases; ``state(t)``, ``push(t)``, ``force(t)`` between the points."""

    def __init__(self, bounds, N, X, W, objective, iterations, duals, outer_max):
        self.bounds, self.N, self.X, self.W = np.asarray(bounds, float), N, X, W
        self.objective, self.iterations, self.duals, self.outer_max = objective, iterations, duals, outer_max
        self.tau = np.array(ca.collocation_points(DEGREE, "radau"))
        mesh = [np.linspace(self.bounds[p], self.bounds[p + 1], N + 1)[:-1] for p in range(3)]
        self.starts = np.concatenate(mesh)                        # 3 N interval starts
        self.ends = np.r_[self.starts[1:], self.bounds[-1]]
        self.t = np.concatenate([[0.0], (self.starts[:, None] + (self.ends - self.starts)[:, None]
                                         * self.tau[None, :]).ravel()])
        _, _, self._F, _ = _system()

    @staticmethod
    def _basis(nodes, s):
        """Lagrange basis of ``nodes`` at ``s``: ``len(s) x len(nodes)``."""
        B = np.ones((len(s), len(nodes)))
        for j, a in enumerate(nodes):
            for r, b in enumerate(nodes):
                if r != j:
                    B[:, j] *= (s - b) / (a - b)
        return B

    def _where(self, t):
        t = np.atleast_1d(np.asarray(t, float))
        k = np.clip(np.searchsorted(self.starts, t, side="right") - 1, 0, len(self.starts) - 1)
        return t, k, (t - self.starts[k]) / (self.ends[k] - self.starts[k])

    def state(self, t) -> np.ndarray:
        t, k, s = self._where(t)
        nodes = np.r_[0.0, self.tau]
        out = np.zeros((self.X.shape[0], len(t)))
        for i in range(len(t)):
            out[:, i] = self.X[:, k[i] * DEGREE: k[i] * DEGREE + DEGREE + 1] @ self._basis(nodes, s[i:i + 1])[0]
        return out

    def push_jumps(self) -> list[float]:
        """The push's jump at ``t1`` and ``t2``: the phase's first interval's polynomial at its start minus the
        push at the previous phase's last point (zero at the optimum: the push is continuous there)."""
        at_start = self._basis(self.tau, np.array([0.0]))[0]
        return [float(self.W[0, k * DEGREE:(k + 1) * DEGREE] @ at_start - self.W[0, k * DEGREE - 1])
                for k in (self.N, 2 * self.N)]

    def push(self, t) -> np.ndarray:
        t, k, s = self._where(t)
        out = np.zeros(len(t))
        for i in range(len(t)):
            out[i] = self.W[0, k[i] * DEGREE: (k[i] + 1) * DEGREE] @ self._basis(self.tau, s[i:i + 1])[0]
        return out

    def force(self, t) -> np.ndarray:
        """The hinge force on the pole, 3 x len(t)."""
        t = np.atleast_1d(np.asarray(t, float))
        return np.asarray(self._F.map(len(t))(self.state(t), self.push(t)[None, :]))


def phase_solve(N: int, t1: float, t2: float, guess=None, continuous_push: bool = False) -> PhaseSolution:
    """Three phases of ``N`` Radau-``DEGREE`` intervals each, ``t1``, ``t2`` free; ``guess(t) -> (X, w)``.

    ``continuous_push``: also the push continuous at ``t1``, ``t2`` (the phase's first interval's push polynomial
    at its start equal to the push at the previous phase's last point). An optimality condition of this problem
    (a mixed input-state bound, the Hamiltonian strictly convex in the push), so it leaves the optimum where it is,
    but it fixes the junction times to first order, where the objective alone fixes them only to second order."""
    s, f, F, F2 = _system()
    T, fmax2 = P["T"], P["f_max"] ** 2
    L = ca.Function("L", [s.w], [ca.sumsqr(s.w)])
    tau, C, B = npb.ref.radau_coefficients(DEGREE)
    opti = ca.Opti()
    tj = opti.variable(2)
    opti.subject_to(opti.bounded(0.05 * T, tj[0], 0.95 * T))
    opti.subject_to(opti.bounded(0.05 * T, tj[1], 0.95 * T))
    opti.subject_to(tj[1] - tj[0] >= 0.01 * T)
    opti.set_initial(tj, [t1, t2])
    edges = [0, tj[0], tj[1], T]
    X = opti.variable(4, 3 * N * DEGREE + 1)
    W = opti.variable(1, 3 * N * DEGREE)
    J, arc, outer = 0, [], []
    for p in range(3):
        h = (edges[p + 1] - edges[p]) / N
        for k in range(p * N, (p + 1) * N):
            cols = [X[:, k * DEGREE + j] for j in range(DEGREE + 1)]
            for j in range(1, DEGREE + 1):
                xp = sum(C[r, j] * cols[r] for r in range(DEGREE + 1))
                wk = W[:, k * DEGREE + j - 1]
                opti.subject_to(xp == h * f(cols[j], wk))
                J += h * B[j] * L(wk)
                g = (F2(cols[j], wk) - fmax2) / fmax2                 # scaled: 0 on the arc
                (arc if p == 1 else outer).append(g)
    g_arc, g_out = ca.vertcat(*arc), ca.vertcat(*outer)
    on_arc = g_arc == 0
    opti.subject_to(on_arc)
    opti.subject_to(g_out <= 0)
    opti.subject_to(X[:, 0] == 0)
    opti.subject_to(X[:, -1] == ca.DM([0.0, math.pi, 0.0, 0.0]))
    if continuous_push:
        at_start = PhaseSolution._basis(tau, np.array([0.0]))[0]
        for p in (1, 2):
            k = p * N
            opti.subject_to(W[0, k * DEGREE - 1] == ca.dot(ca.DM(at_start), W[0, k * DEGREE:(k + 1) * DEGREE].T))
    if guess is not None:
        # the phases' points at the guessed t1, t2
        tau_ = np.array(ca.collocation_points(DEGREE, "radau"))
        e = [0.0, t1, t2, T]
        starts = np.concatenate([np.linspace(e[p], e[p + 1], N + 1)[:-1] for p in range(3)])
        ends = np.r_[starts[1:], T]
        tt = np.concatenate([[0.0], (starts[:, None] + (ends - starts)[:, None] * tau_[None, :]).ravel()])
        Xg, wg = guess(tt)
        opti.set_initial(X, Xg)
        opti.set_initial(W, wg[None, 1:])
    opti.minimize(J)
    opti.solver("ipopt", {"print_time": False}, {"print_level": 0, "sb": "yes", "tol": TOL, "max_iter": 3000,
                                                   "acceptable_iter": 0 if STRICT else 15})
    sol = opti.solve()
    status = sol.stats()["return_status"]
    tv = np.asarray(sol.value(tj)).ravel()
    duals = np.asarray(sol.value(opti.dual(on_arc))).ravel()     # the arc's multipliers (of the scaled bound)
    out = PhaseSolution([0.0, tv[0], tv[1], T], N, np.asarray(sol.value(X)), np.atleast_2d(sol.value(W)),
                        float(sol.value(J)), int(sol.stats()["iter_count"]), duals, float(np.max(sol.value(g_out))))
    out.continuous_push, out.status = continuous_push, status
    return out


# -- 3. the library's solution ---------------------------------------------------------------------------------
def library_solve(tolerance: float) -> dict:
    """The library's refined solve: states and hinge force at its points and midway between them, its junctions."""
    from ocp_constraints.mechanics.load_columns import load_columns
    from ocp_constraints.ocp.switch_detection import detect_switches
    started = time.time()
    sol = npb.cart_pole().solve(tolerance=tolerance)
    wall = time.time() - started
    tr, T = sol.transcription, sol.t_final
    eqs = sol.trajectory.eqs
    mid = 0.5 * (sol.t[1:] + sol.t[:-1])
    E = tr.interpolation_matrix(mid / T)              # each interval's collocation polynomial, as sol.polynomial
    X, lam = np.asarray(sol.X, float), np.asarray(sol.lam, float)
    between = load_columns(eqs, mid, E @ X[: eqs.nq].T, E @ X[eqs.nq:].T, E @ lam.T)
    at = sol.loads()
    mr = sol.mesh_refinement or {}
    return dict(t=np.asarray(sol.t), T=T, mesh=np.asarray(tr.scheme.mesh_fractions), objective=sol.objective,
                junctions=np.array(sorted(w.fraction for w in detect_switches(sol) if w.kind == "junction")),
                X=np.vstack([sol.sample(n) for n in NAMES]), F=np.vstack([at[k] for k in FORCE]), mid=mid,
                Xmid=np.vstack([sol.interpolate(n, mid) for n in NAMES]), Fmid=np.vstack([between[k] for k in FORCE]),
                met=bool(mr.get("met", False)), estimate={k: float(v) for k, v in mr.get("estimate", {}).items()},
                wall=wall, iterations=sol.iterations, success=sol.success)


def _spread(a: PhaseSolution, b: PhaseSolution, scale: float) -> dict:
    """``a`` against ``b`` at ``b``'s points and midway between them (off the phase boundaries of either)."""
    t = b.t
    t = np.unique(np.r_[t, 0.5 * (t[1:] + t[:-1])])
    t = t[np.min(np.abs(t[:, None] - np.r_[a.bounds, b.bounds][None, :]), axis=1) > 1e-9]
    dX = np.abs(a.state(t) - b.state(t))
    dF = np.abs(a.force(t) - b.force(t)).max(axis=0) / scale
    return dict(states=dX.max(), states_at=t[np.argmax(dX.max(axis=0))], force=dF.max(), force_at=t[np.argmax(dF)],
                t1=abs(a.bounds[1] - b.bounds[1]), t2=abs(a.bounds[2] - b.bounds[2]),
                objective=abs(a.objective - b.objective))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--tolerance", type=float, default=1e-5, help="the library's refinement tolerance")
    ap.add_argument("--per-phase", type=int, nargs="+", default=[40, 80, 160], help="intervals per phase, coarse to fine")
    ap.add_argument("--uniform", type=int, default=100, help="intervals of the uniform solve for the arc structure")
    ap.add_argument("--library-npz", type=Path, help="reuse the library's solution saved here (saved if missing)")
    args = ap.parse_args()
    T = P["T"]

    # 1. the arc structure
    started = time.time()
    u = uniform_solve(args.uniform)
    arcs = arcs_of(u["t"][1:], u["F2"])
    print(f"uniform Radau {DEGREE} on {args.uniform} intervals: J = {u['objective']:.10f} ({u['iterations']} "
          f"iterations, {time.time() - started:.0f} s); |F| = f_max (to 1e-6) on "
          + ", ".join(f"[{a / T:.5f}, {b / T:.5f}]" for a, b in arcs) + " of the horizon (first and last active point)")
    if len(arcs) != 1:
        raise SystemExit("not one arc: the three-phase reference does not apply")
    dt = T / args.uniform                              # the junctions lie within one interval outside the active points
    t1, t2 = arcs[0][0] - 0.5 * dt / DEGREE, arcs[0][1] + 0.5 * dt / DEGREE

    def guess(tt):
        return (np.vstack([np.interp(tt, u["t"], u["X"][i]) for i in range(4)]), np.interp(tt, u["t"][1:], u["W"][0]))

    # 2. the phase references
    refs = []
    for N in args.per_phase:            # each from the uniform solve, then each finer one from the one before
        started = time.time()
        r = phase_solve(N, t1, t2, guess)
        refs.append(r)
        t1, t2 = r.bounds[1], r.bounds[2]

        def guess(tt, r=r):
            return r.state(tt), r.push(tt)
        dense = np.linspace(0.0, T, 40001)
        over = float((r.force(dense) ** 2).sum(axis=0).max() - P["f_max"] ** 2)
        print(f"phase reference, {N} intervals per phase ({3 * N * DEGREE + 1} points): J = {r.objective:.10f}, "
              f"t1 = {r.bounds[1] / T:.8f}, t2 = {r.bounds[2] / T:.8f} of the horizon ({r.iterations} iterations, "
              f"IPOPT {r.status}, {time.time() - started:.0f} s)")
        print(f"    outer phases: largest (|F|^2 - f_max^2)/f_max^2 at their points {r.outer_max:.1e}; arc multipliers "
              f"(scaled) {r.duals.min():.2e} ... {r.duals.max():.2e}; largest |F|^2 - f_max^2 on 40001 uniform times "
              f"{over:.1e} N^2; push jump at t1, t2: {r.push_jumps()[0]:+.1e}, {r.push_jumps()[1]:+.1e} N")
    fine = refs[-1]
    scale = float(np.abs(fine.force(fine.t[1:])).max())
    for a, b in zip(refs[:-1], refs[1:]):
        d = _spread(a, b, scale)
        print(f"  {a.N} against {b.N} per phase: states {d['states']:.1e} (at {d['states_at'] / T:.4f}), hinge force "
              f"{d['force']:.1e} of {scale:.2f} N (at {d['force_at'] / T:.4f}), t1 {d['t1'] / T:.1e}, t2 "
              f"{d['t2'] / T:.1e} of the horizon, objective {d['objective']:.1e}")

    # 3. the library against the finer phase reference
    if args.library_npz and args.library_npz.exists():
        lib = dict(np.load(args.library_npz, allow_pickle=True))
        lib = {k: (v.item() if v.dtype == object else v) for k, v in lib.items()}
    else:
        lib = library_solve(args.tolerance)
        if args.library_npz:
            np.savez(args.library_npz, **lib)
    print(f"library, tolerance {args.tolerance:g}: met {lib['met']}, {len(lib['t'])} points on {len(lib['mesh']) - 1} "
          f"intervals, estimate {lib['estimate']}, J = {lib['objective']:.10f} ({lib['wall']:.0f} s)")
    t_at, t_mid = lib["t"][1:], lib["mid"]           # Radau: no collocation point (no force) at t = 0
    e_X_at = np.abs(lib["X"][:, 1:] - fine.state(t_at))
    e_X_mid = np.abs(lib["Xmid"] - fine.state(t_mid))
    e_F_at = np.abs(lib["F"][:, 1:] - fine.force(t_at)).max(axis=0) / scale
    e_F_mid = np.abs(lib["Fmid"] - fine.force(t_mid)).max(axis=0) / scale
    for what, eX, eF, tt in (("at its points", e_X_at, e_F_at, t_at), ("midway between them", e_X_mid, e_F_mid, t_mid)):
        per = ", ".join(f"{n} {eX[i].max():.1e}" for i, n in enumerate(NAMES))
        print(f"  {what}: states {eX.max():.1e} (at {tt[np.argmax(eX.max(axis=0))] / T:.5f}; {per}); hinge force "
              f"{eF.max():.1e} of {scale:.2f} N (at {tt[np.argmax(eF)] / T:.5f})")
        away = np.min(np.abs(tt[:, None] / T - np.r_[fine.bounds[1:3] / T, lib["junctions"]][None, :]), axis=1) > 2e-3
        print(f"    more than 2e-3 of the horizon from every junction (theirs and ours): states {eX[:, away].max():.1e}, "
              f"hinge force {eF[away].max():.1e}")
    over = float((lib["Fmid"] ** 2).sum(axis=0).max() - P["f_max"] ** 2)
    print(f"  library's largest |F|^2 - f_max^2 midway between its points: {over:.1e} N^2")
    print(f"  objective: library - reference = {lib['objective'] - fine.objective:.2e}")
    mesh = lib["mesh"]
    for name, ours, theirs in zip(("t1", "t2"), lib["junctions"], fine.bounds[1:3] / T):
        k = int(np.clip(np.searchsorted(mesh, theirs, side="right") - 1, 0, len(mesh) - 2))
        h = mesh[k + 1] - mesh[k]
        print(f"  {name}: library located {ours:.8f}, reference {theirs:.8f} of the horizon: off by {ours - theirs:+.2e} "
              f"({(ours - theirs) * T:+.2e} s); the reference's {name} lies in the library's interval {k} "
              f"[{mesh[k]:.8f}, {mesh[k + 1]:.8f}] (width {h:.2e}), at {(theirs - mesh[k]) / h:.3f} of it")


if __name__ == "__main__":
    main()
