"""Independent references for newcomer check 5, without ocp_constraints' transcription or equations.

Lagrange's equations in minimal coordinates (tests/newcomer_reference.py: LagrangeSystem builds M qdd = rhs from the
bodies' energies), transcribed here in plain CasADi Opti by Radau IIA collocation of degree DEG on a mesh, solved by
IPOPT at tol 1e-12. Joint forces by Newton on each body from the accelerations. Where a constraint is active on an arc
(problems pend and rp) the reference is solved twice: first on a uniform mesh to find the arc, then in phases
(free / arc / free) whose junction times are NLP variables, so the junctions are mesh points and the kinks of the
inputs and loads are resolved.

    python ref.py PROBLEM        # PROBLEM in dpend, pend, rp, ft; writes ref_PROBLEM.npz (two resolutions compared)
Env: NREF (intervals of the coarse one; the fine one has twice as many), DREF (degree), GUESS_MESH ("degree,N" of
the library's fixed-mesh solve used as the initial guess only; default "3,40"), SUFFIX (appended to the file name).
"""
import importlib.util, json, math, os, sys, time
import casadi as ca
import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
_spec = importlib.util.spec_from_file_location("newcomer_reference", os.path.join(HERE, "..", "..", "tests", "newcomer_reference.py"))
R = importlib.util.module_from_spec(_spec); sys.modules["newcomer_reference"] = R; _spec.loader.exec_module(R)
sys.path.insert(0, HERE)
import models as M   # only the parameter dictionaries (DP, PF, RP, FT) are read here, and the library solution as a guess

Gv = np.array([0.0, -M.G, 0.0])


def e(a):
    return ca.vertcat(ca.cos(a), ca.sin(a), 0)


def rodJ(m, L):
    return np.diag([1e-4, m * L ** 2 / 12, m * L ** 2 / 12])


def accel(s, xexpr):
    """Acceleration of a point xexpr(q) as an expression of (q, qd, w) (qdd from Lagrange's equations)."""
    v = ca.jtimes(xexpr, s.q, s.qd)
    return ca.jtimes(v, s.q, s.qd) + ca.jtimes(v, s.qd, s.qdd)


def body_states(s, named):
    """Each body's center of mass position and velocity (x, y, vbar_x, vbar_y), angle and rate (psi, omega_z) as
    expressions of (q, qd): the quantities the library's states estimate covers (its bodies' coordinates and
    speeds; z, theta, phi and the out-of-plane speeds are zero here)."""
    out = {}
    for name, (c, ang) in named.items():
        v = ca.jtimes(c, s.q, s.qd)
        out.update({f"{name}.x": c[0], f"{name}.y": c[1], f"{name}.vbar_x": v[0], f"{name}.vbar_y": v[1],
                    f"{name}.psi": ang, f"{name}.omega_z": ca.jtimes(ang, s.q, s.qd)})
    return out


# ------------------------------------------------------------------ the four systems
def system(P):
    """Returns a dict: s (LagrangeSystem), lag (integrand of x, w), states (name -> expr of q, qd),
    loads (name -> expr of q, qd, w: the library's multiplier channels, with their describe() meaning),
    path (expr, lower, upper) or None, sbound (state index, upper) or None, initial, final, T, free time data."""
    if P == "dpend":
        p = M.DP
        q, w = ca.SX.sym("q", 2), ca.SX.sym("w", 2)
        c1 = p["L1"] / 2 * e(q[0]); c2 = p["L1"] * e(q[0]) + p["L2"] / 2 * e(q[1])
        bodies = [R.RigidBody(p["m1"], rodJ(p["m1"], p["L1"]), c1, R.rot3(q[0])),
                  R.RigidBody(p["m2"], rodJ(p["m2"], p["L2"]), c2, R.rot3(q[1]))]
        s0 = R.LagrangeSystem(q, w, bodies, Gv)
        Q = s0.torque_work(0, ca.vertcat(0, 0, w[0] - w[1])) + s0.torque_work(1, ca.vertcat(0, 0, w[1]))
        s = R.LagrangeSystem(q, w, bodies, Gv, Q)
        Fel = p["m2"] * (accel(s, c2) - Gv)              # on the lower rod at E
        Fsh = p["m1"] * (accel(s, c1) - Gv) + Fel        # on the upper rod at S
        lag = ca.sumsqr(w) + p["w_load"] * ca.sumsqr(Fsh)
        states = {"upper.psi": q[0], "lower.psi": q[1], "upper.omega_z": s.qd[0], "lower.omega_z": s.qd[1],
                  "elbow.angle": q[1] - q[0], "elbow.rate": s.qd[1] - s.qd[0]}
        loads = {"shoulder.v1": Fsh[0], "shoulder.v2": Fsh[1], "elbow.v1": Fel[0], "elbow.v2": Fel[1]}
        zeros = ["shoulder.v3", "shoulder.w1", "shoulder.w2", "elbow.v3", "elbow.w1", "elbow.w2"]
        body = body_states(s, {"upper": (c1, q[0]), "lower": (c2, q[1])})
        return dict(s=s, lag=lag, states=states, body=body, loads=loads, zeros=zeros, path=None, sbound=None,
                    initial={0: -math.pi / 2, 1: -math.pi / 2, 2: 0, 3: 0},
                    final={0: math.pi / 2, 1: math.pi / 2, 2: 0, 3: 0}, T=p["T"], free=None, angles=["upper.psi", "lower.psi", "elbow.angle"],
                    guess_names=(["upper.psi", "lower.psi"], ["upper.omega_z", "lower.omega_z"], ["tau1", "tau2"]))
    if P in ("pend", "ft"):
        p = M.PF if P == "pend" else M.FT
        q, w = ca.SX.sym("q", 1), ca.SX.sym("w", 1)
        c = p["L"] / 2 * e(q[0])
        bodies = [R.RigidBody(p["m"], rodJ(p["m"], p["L"]), c, R.rot3(q[0]))]
        s0 = R.LagrangeSystem(q, w, bodies, Gv)
        s = R.LagrangeSystem(q, w, bodies, Gv, s0.torque_work(0, ca.vertcat(0, 0, w[0])))
        F = p["m"] * (accel(s, c) - Gv)                   # on the rod at the hinge
        states = {"rod.psi": q[0], "rod.omega_z": s.qd[0]}
        loads = {"hinge.v1": F[0], "hinge.v2": F[1]}
        zeros = ["hinge.v3", "hinge.w1", "hinge.w2"]
        base = dict(s=s, states=states, body=body_states(s, {"rod": (c, q[0])}), loads=loads, zeros=zeros, sbound=None, angles=["rod.psi"],
                    input_bounds=(-p["tau_max"], p["tau_max"]),
                    guess_names=(["rod.psi"], ["rod.omega_z"], ["tau"]))
        if P == "pend":
            base.update(lag=ca.sumsqr(w), path=(ca.sumsqr(F), 0.0, p["F_max"] ** 2), initial={0: -math.pi / 2, 1: 0},
                        final={0: math.pi / 2, 1: 0}, T=p["T"], free=None)
        else:
            base.update(lag=p["w_eff"] * ca.sumsqr(w), path=None, initial={0: -math.pi / 2, 1: 0}, final={1: 0},
                        T=p["T0"], free=dict(bounds=p["Tb"], time_weight=1.0,
                                             terminal=lambda xT: p["W"] * (xT[0] - p["target"]) ** 2))
        return base
    if P == "rp":
        p = M.RP
        q, w = ca.SX.sym("q", 2), ca.SX.sym("w", 2)     # slider x, arm angle; force, tau
        cs = ca.vertcat(q[0], 0, 0); ca_ = cs + p["L"] / 2 * e(q[1])
        bodies = [R.RigidBody(p["m_s"], 0.02 * np.eye(3), cs, ca.DM.eye(3)),
                  R.RigidBody(p["m_a"], rodJ(p["m_a"], p["L"]), ca_, R.rot3(q[1]))]
        s0 = R.LagrangeSystem(q, w, bodies, Gv)
        Q = s0.force_work(cs, ca.vertcat(w[0], 0, 0)) + s0.torque_work(1, ca.vertcat(0, 0, w[1])) \
            + s0.torque_work(0, ca.vertcat(0, 0, -w[1]))
        s = R.LagrangeSystem(q, w, bodies, Gv, Q)
        Fpin = p["m_a"] * (accel(s, ca_) - Gv)            # on the arm at P
        # slider: 0 = n1 - Fpin_y - m_s g (y);  0 = w3 - tau (z moment; the pin is at its center)
        loads = {"pin.v1": Fpin[0], "pin.v2": Fpin[1], "rail.n1": p["m_s"] * M.G + Fpin[1], "rail.w3": w[1]}
        zeros = ["pin.v3", "pin.w1", "pin.w2", "rail.n2", "rail.w1", "rail.w2"]
        states = {"slider.x": q[0], "arm.psi": q[1], "slider.vbar_x": s.qd[0], "arm.omega_z": s.qd[1]}
        body = body_states(s, {"slider": (cs, ca.SX(0)), "arm": (ca_, q[1])})
        return dict(s=s, lag=w[0] ** 2 + p["w_tau"] * w[1] ** 2, states=states, body=body, loads=loads, zeros=zeros, path=None,
                    sbound=(1, p["psi_max"]), initial={0: 0, 1: -math.pi / 2, 2: 0, 3: 0},
                    final={0: p["D"], 1: -math.pi / 2, 2: 0, 3: 0}, T=p["T"], free=None, angles=["arm.psi"],
                    guess_names=(["slider.x", "arm.psi"], ["slider.vbar_x", "arm.omega_z"], ["force", "tau"]))
    raise SystemExit(f"unknown problem {P}")


# ------------------------------------------------------------------ Radau IIA collocation, optionally in phases
def transcribe(S, N, degree, guess, arcs=None):
    """arcs: None (one phase, uniform mesh) or a list of (start fraction guess, end fraction guess) of arcs where the
    path constraint (or the state bound) holds with equality; the junctions are variables, each phase has a share of
    the N intervals by its length (at least 3)."""
    s = S["s"]; n, m = s.q.numel(), s.w.numel()
    x = ca.vertcat(s.q, s.qd)
    f = ca.Function("f", [x, s.w], [ca.vertcat(s.qd, s.qdd), S["lag"]])
    pf = ca.Function("p", [x, s.w], [S["path"][0]]) if S["path"] else None
    tau, C, B = R.radau_coefficients(degree)
    opti = ca.Opti()
    free = S["free"]
    T = opti.variable() if free else S["T"]
    if free:
        opti.subject_to(opti.bounded(free["bounds"][0], T, free["bounds"][1]))
    # phases
    if not arcs:
        mesh = ca.DM(np.linspace(0, 1, N + 1)); kinds = [False] * N; junctions = []
    else:
        bounds_g = [0.0] + [v for a in arcs for v in a] + [1.0]
        lengths = np.diff(bounds_g)
        counts = np.maximum(3, np.round(N * lengths / lengths.sum())).astype(int)
        jv = [opti.variable() for _ in range(len(bounds_g) - 2)]
        for v, g in zip(jv, bounds_g[1:-1]):
            opti.set_initial(v, g)
        ends = [0.0] + jv + [1.0]
        for a, b in zip(ends[:-1], ends[1:]):
            opti.subject_to(b - a >= 1e-3)
        parts, kinds = [ca.DM([0.0])], []
        for k, Nk in enumerate(counts):
            parts.append(ends[k] + (ends[k + 1] - ends[k]) * ca.DM(np.linspace(0, 1, Nk + 1)[1:]))
            kinds += [k % 2 == 1] * int(Nk)
        mesh = ca.vertcat(*parts); N = int(counts.sum()); junctions = jv
    X = opti.variable(2 * n, N * degree + 1); W = opti.variable(m, N * degree)
    J = free["time_weight"] * T if free else 0
    for k in range(N):
        h = T * (mesh[k + 1] - mesh[k])
        cols = [X[:, k * degree + j] for j in range(degree + 1)]
        for j in range(1, degree + 1):
            xp = sum(C[r, j] * cols[r] for r in range(degree + 1))
            wk = W[:, k * degree + j - 1]
            dx, L = f(cols[j], wk)
            opti.subject_to(xp == h * dx)
            J += h * B[j] * L
            if S.get("input_bounds"):
                opti.subject_to(opti.bounded(S["input_bounds"][0], wk, S["input_bounds"][1]))
            if pf is not None:
                g = pf(cols[j], wk)
                if kinds[k]:
                    opti.subject_to(g == S["path"][2])
                else:
                    opti.subject_to(opti.bounded(S["path"][1], g, S["path"][2]))
        if S["sbound"]:
            i, up = S["sbound"]
            entry = kinds[k] and (k == 0 or not kinds[k - 1])
            if entry:   # the arc starts here: angle at the bound and its rate zero (the rate is not implied there)
                opti.subject_to(X[n + i, k * degree] == 0)
            for j in range(0 if entry else 1, degree + 1):
                if kinds[k]:
                    opti.subject_to(X[i, k * degree + j] == up)
                else:
                    opti.subject_to(X[i, k * degree + j] <= up)
    for i, v in S["initial"].items():
        opti.subject_to(X[i, 0] == v)
    for i, v in S["final"].items():
        opti.subject_to(X[i, -1] == v)
    if free and free.get("terminal"):
        J += free["terminal"](X[:, -1])
    # guess
    mesh_g = np.asarray(ca.evalf(ca.substitute(mesh, ca.vertcat(*junctions), ca.DM([v for a in (arcs or []) for v in a])))
                        if junctions else mesh).ravel()
    frac = np.concatenate([[0.0], (mesh_g[:-1, None] + np.diff(mesh_g)[:, None] * tau[None, :]).ravel()])
    gx, gw, gT = guess(frac)
    opti.set_initial(X, gx); opti.set_initial(W, gw[:, 1:])
    if free:
        opti.set_initial(T, gT)
    opti.minimize(J)
    opti.solver("ipopt", {"print_time": False}, {"print_level": 0, "sb": "yes", "tol": 1e-12, "max_iter": 5000})
    sol = opti.solve()
    Tv = float(sol.value(T)) if free else float(S["T"])
    mesh_v = np.asarray(sol.value(mesh)).ravel()
    frac = np.concatenate([[0.0], (mesh_v[:-1, None] + np.diff(mesh_v)[:, None] * tau[None, :]).ravel()])
    Xv, Wv = np.atleast_2d(sol.value(X)), np.atleast_2d(sol.value(W))
    # quantities: states at every node, loads at the collocation nodes (with the inputs there)
    qs = ca.Function("qs", [x], [ca.vertcat(*S["states"].values())])
    ql = ca.Function("ql", [x, s.w], [ca.vertcat(*S["loads"].values())])
    st = np.asarray(qs(Xv)).reshape(len(S["states"]), -1)
    ld = np.asarray(ql(Xv[:, 1:], Wv)).reshape(len(S["loads"]), -1)
    pv = np.asarray(pf(Xv[:, 1:], Wv)).ravel() if pf is not None else None
    return {"objective": float(sol.value(J)), "T": Tv, "mesh": mesh_v, "frac": frac, "degree": degree, "tau": tau,
            "X": Xv, "W": Wv, "states": dict(zip(S["states"], st)), "loads": dict(zip(S["loads"], ld)),
            "path_values": pv, "junctions": [float(sol.value(v)) for v in junctions],
            "iterations": int(sol.stats()["iter_count"])}


def evaluate(ref, name, fq, kind):
    """The reference's polynomial of a state (through the interval's start and collocation nodes) or of a load
    (through the collocation nodes only: inputs and loads may kink at a mesh point) at fractions fq of the horizon.
    A point on a mesh point belongs to the interval ending there (Radau's right end node)."""
    mesh, d, tau = ref["mesh"], ref["degree"], ref["tau"]
    N = len(mesh) - 1
    fq = np.atleast_1d(np.asarray(fq, float))
    k = np.clip(np.searchsorted(mesh, fq, side="left") - 1, 0, N - 1)
    vals = ref["states"][name] if kind == "state" else ref["loads"][name]
    out = np.zeros(len(fq))
    for i, (fv, kk) in enumerate(zip(fq, k)):
        a, b = mesh[kk], mesh[kk + 1]
        if kind == "state":
            xs = np.r_[0.0, tau]; ys = vals[kk * d: kk * d + d + 1]
        else:
            xs = tau; ys = vals[kk * d: kk * d + d]
        z = (fv - a) / (b - a)
        out[i] = sum(ys[j] * np.prod([(z - xs[r]) / (xs[j] - xs[r]) for r in range(len(xs)) if r != j])
                     for j in range(len(xs)))
    return out


def find_arcs(S, ref, rel=1e-7):
    """Arcs of the uniform solution: runs of collocation points where the constraint is active."""
    if S["path"]:
        act = ref["path_values"] >= S["path"][2] * (1 - rel)
        tpts = ref["frac"][1:]
    else:
        i, up = S["sbound"]
        act = ref["X"][i] >= up - rel
        tpts = ref["frac"]
    arcs, start = [], None
    for a, t in zip(act, tpts):
        if a and start is None:
            start = t; last = t
        elif a:
            last = t
        elif start is not None:
            arcs.append((start, last)); start = None
    if start is not None:
        arcs.append((start, last))
    return [a for a in arcs if a[1] - a[0] > 0.005], arcs


def main(P):
    import ocp_constraints as oc
    S = system(P)
    build = {"dpend": M.dpend, "pend": M.pend_force, "rp": M.rp, "ft": M.free_time}[P]
    c0 = time.process_time()
    gdeg, gN = (int(v) for v in os.environ.get("GUESS_MESH", "3,40").split(","))
    lib = build().solve(oc.Radau(gN, degree=gdeg))
    print(f"library Radau {gdeg} x {gN} (the guess only): {lib.status} objective {lib.objective:.10g} T {lib.t_final:.8g} "
          f"cpu {time.process_time() - c0:.1f}")
    qn, rn, wn = S["guess_names"]

    def guess_lib(frac):
        t = frac * lib.t_final
        X = np.vstack([lib.interpolate(nm, t) for nm in qn] + [lib.interpolate(nm, t) for nm in rn])
        Wg = np.vstack([lib.interpolate(nm, np.maximum(t, 1e-9)) for nm in wn])
        return X, Wg, lib.t_final

    deg = int(os.environ.get("DREF", 7)); N = int(os.environ.get("NREF", 60))
    arcs = None
    if S["path"] or S["sbound"]:
        c0 = time.process_time()
        uni = transcribe(S, 2 * N, deg, guess_lib)
        arcs, raw = find_arcs(S, uni)
        print(f"uniform {2 * N} x {deg}: objective {uni['objective']:.12g}, cpu {time.process_time() - c0:.1f}; "
              f"active runs {raw}; arcs kept {arcs}")
        def guess_uni(frac, uni=uni):
            X = np.vstack([np.interp(frac, uni["frac"], r) for r in uni["X"]])
            Wg = np.vstack([np.interp(frac, uni["frac"][1:], r) for r in uni["W"]])
            return X, Wg, uni["T"]
        gfun = guess_uni
    else:
        gfun = guess_lib
    refs = []
    for n in (N, 2 * N):
        c0 = time.process_time()
        r = transcribe(S, n, deg, gfun, arcs=arcs)
        print(f"reference N={len(r['mesh']) - 1} degree {deg}: objective {r['objective']:.14g} T {r['T']:.12g} "
              f"junctions {np.round(r['junctions'], 8).tolist()} iterations {r['iterations']} cpu {time.process_time() - c0:.1f}")
        refs.append(r)
    coarse, fine = refs
    acc_s = max(float(np.abs(evaluate(fine, k, coarse["frac"], "state") - coarse["states"][k]).max()) for k in S["states"])
    peak = max(float(np.abs(v).max()) for v in fine["loads"].values())
    acc_m = max(float(np.abs(evaluate(fine, k, coarse["frac"][1:], "load") - coarse["loads"][k]).max()) for k in S["loads"]) / peak
    fine["accuracy"] = {"states_coarse_vs_fine": acc_s, "loads_coarse_vs_fine_rel_peak": acc_m,
                        "objective_coarse": coarse["objective"], "objective_fine": fine["objective"],
                        "T_coarse": coarse["T"], "T_fine": fine["T"], "peak_load": peak, "arcs_uniform": arcs,
                        "junctions_coarse": coarse["junctions"], "junctions_fine": fine["junctions"],
                        "N": [len(coarse["mesh"]) - 1, len(fine["mesh"]) - 1], "degree": deg,
                        "lib_guess_objective": float(lib.objective)}
    if S["path"]:
        fine["accuracy"]["path_max_minus_bound"] = float(fine["path_values"].max() - S["path"][2])
    if S["sbound"]:
        fine["accuracy"]["state_max_minus_bound"] = float(fine["X"][S["sbound"][0]].max() - S["sbound"][1])
    print(json.dumps(fine["accuracy"]))
    fine["zeros"] = S["zeros"]; fine["angles"] = S["angles"]
    fine["accuracy"]["guess_mesh"] = f"library Radau {gdeg} x {gN}"
    np.savez(os.path.join(HERE, f"ref_{P}{os.environ.get('SUFFIX', '')}.npz"), ref=np.array(fine, dtype=object))


if __name__ == "__main__":
    main(sys.argv[1])
