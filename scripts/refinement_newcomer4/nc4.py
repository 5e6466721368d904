"""Newcomer check 4: four problems, solve(tolerance=TOL) against independent minimal-coordinate references.

    python nc4.py ref PROBLEM            # build the reference (two resolutions), saved to ref_PROBLEM.npz
    python nc4.py run PROBLEM TOL        # one refined solve, its record as JSON on the last line
    python nc4.py all [PROBLEM ...]      # every tolerance, one subprocess at a time (timeout 150 s, CPU cap 120 s)
"""
import importlib.util, json, math, os, resource, subprocess, sys, time
import casadi as ca
import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
_spec = importlib.util.spec_from_file_location("newcomer_reference", os.path.join(HERE, "..", "..", "tests", "newcomer_reference.py"))
R = importlib.util.module_from_spec(_spec); sys.modules["newcomer_reference"] = R; _spec.loader.exec_module(R)
G = np.array([0.0, -9.81, 0.0])
TOLS = ["1e-3", "1e-4", "1e-5", "1e-6"]


def rod(m, L, axis=0):
    J = np.full(3, m * L ** 2 / 12); J[axis] = 1e-4; return np.diag(J)


# ================================================================ reference transcription (plain CasADi Opti)
PHASE_GAP = 0.01
ARC = None   # (first interval, last interval + 1, state index, value): held on those intervals' points


def radau(s, N, T, lag, initial, final, degree=3, input_bounds=None, path=None, free_time=None, time_weight=0.0,
          guess=None, mesh=None, touch=None, phases=None, pins=None):
    """touch: (N1, fraction guess, {state index: value at the touch}) puts mesh point N1 at a free fraction.
    Radau collocation of x = (q, qd), x' = (qd, qdd) with lagrangian lag(x, w, t) (t absolute time)."""
    n, m = s.q.numel(), s.w.numel()
    x = ca.vertcat(s.q, s.qd); tt = ca.SX.sym("t")
    f = ca.Function("f", [x, s.w, tt], [ca.vertcat(s.qd, s.qdd), lag(x, s.w, tt)])
    tau, C, B = R.radau_coefficients(degree)
    opti = ca.Opti()
    Tv = opti.variable() if free_time else T
    if free_time:
        opti.subject_to(opti.bounded(free_time[0], Tv, free_time[1])); opti.set_initial(Tv, T)
    mesh = np.linspace(0, 1, N + 1) if mesh is None else np.asarray(mesh, float)
    if touch is not None:
        N1 = touch[0]; s1 = opti.variable(); opti.set_initial(s1, touch[1])
        opti.subject_to(opti.bounded(0.05, s1, 0.95))
        mesh = ca.vertcat(s1 * ca.DM(np.linspace(0, 1, N1 + 1)), s1 + (1 - s1) * ca.DM(np.linspace(0, 1, N - N1 + 1)[1:]))
    fixed_w = {}
    if phases is not None:   # [(intervals, end fraction guess or None for the last, input value or None)]
        parts, ends_num, start, start_num, k0 = [], [], 0, 0.0, 0
        for (Nk, fend, wfix) in phases:
            if fend is None:
                end, end_num = 1, 1.0
            else:
                end = opti.variable(); opti.set_initial(end, fend); end_num = fend
                opti.subject_to(end >= start + PHASE_GAP)
            parts.append(start + (end - start) * ca.DM(np.linspace(0, 1, Nk + 1))[(1 if k0 else 0):])
            ends_num.append(start_num + (end_num - start_num) * np.linspace(0, 1, Nk + 1)[(1 if k0 else 0):])
            if wfix is not None:
                for k in range(k0, k0 + Nk):
                    fixed_w[k] = wfix
            start, start_num, k0 = end, end_num, k0 + Nk
        mesh = ca.vertcat(*parts); mesh_ph = np.concatenate(ends_num); N = k0
    X = opti.variable(2 * n, N * degree + 1); W = opti.variable(m, N * degree)
    J = time_weight * Tv if free_time else 0
    for k in range(N):
        h = Tv * (mesh[k + 1] - mesh[k])
        cols = [X[:, k * degree + j] for j in range(degree + 1)]
        for j in range(1, degree + 1):
            xp = sum(C[r, j] * cols[r] for r in range(degree + 1))
            wk = W[:, k * degree + j - 1]
            tk = Tv * (mesh[k] + (mesh[k + 1] - mesh[k]) * tau[j - 1])
            dx, L = f(cols[j], wk, tk)
            opti.subject_to(xp == h * dx)
            J += h * B[j] * L
            if path:
                for fn, lo, up in path:
                    opti.subject_to(opti.bounded(lo, fn(cols[j], wk), up))
            if k in fixed_w:
                opti.subject_to(wk == fixed_w[k])
            elif input_bounds is not None:
                opti.subject_to(opti.bounded(input_bounds[0], wk, input_bounds[1]))
    if ARC is not None:
        for k in range(ARC[0] * degree, ARC[1] * degree + 1):
            opti.subject_to(X[ARC[2], k] == ARC[3])
    if pins:   # (interval, "start" | "end", value): the interval's input polynomial there equals value
        ell0 = np.array([np.prod([(0 - tau[r]) / (tau[j] - tau[r]) for r in range(degree) if r != j]) for j in range(degree)])
        for k, side, v in pins:
            if side == "start":
                opti.subject_to(sum(ell0[j] * W[:, k * degree + j] for j in range(degree)) == v)
            else:
                opti.subject_to(W[:, k * degree + degree - 1] == v)
    if touch is not None:
        for i, v in touch[2].items():
            opti.subject_to(X[i, touch[0] * degree] == v)
    for i, v in initial.items():
        opti.subject_to(X[i, 0] == v)
    for i, v in final.items():
        opti.subject_to(X[i, -1] == v)
    if touch is not None:
        mesh_num = np.r_[touch[1] * np.linspace(0, 1, N1 + 1), touch[1] + (1 - touch[1]) * np.linspace(0, 1, N - N1 + 1)[1:]]
    elif phases is not None:
        mesh_num = mesh_ph
    else:
        mesh_num = mesh
    tfrac = np.concatenate([[0.0], (mesh_num[:-1, None] + np.diff(mesh_num)[:, None] * tau[None, :]).ravel()])
    if guess is not None:   # guess(frac) -> (X at frac, W at frac, T)
        gx, gw, gT = guess(tfrac)
        opti.set_initial(X, gx); opti.set_initial(W, gw[:, 1:])
        if free_time:
            opti.set_initial(Tv, gT)
    opti.minimize(J)
    opti.solver("ipopt", {"print_time": False}, {"print_level": 0, "sb": "yes", "tol": 1e-12, "max_iter": 3000})
    sol = opti.solve()
    Tf = float(sol.value(Tv)) if free_time else float(T)
    if touch is not None or phases is not None:
        mesh = np.asarray(sol.value(mesh)).ravel()
        tfrac = np.concatenate([[0.0], (mesh[:-1, None] + np.diff(mesh)[:, None] * tau[None, :]).ravel()])
    return {"objective": float(sol.value(J)), "t": tfrac * Tf, "frac": tfrac, "X": np.atleast_2d(sol.value(X)),
            "W": np.atleast_2d(sol.value(W)), "T": Tf, "iterations": int(sol.stats()["iter_count"])}


def kin(s, body):
    """CasADi functions of (q, qd, qdd): com position, velocity, acceleration, angle-rate omega_z and alpha_z."""
    b = s.bodies[body]; qdd = ca.SX.sym("qdd", s.q.numel())
    v = ca.jtimes(b.x, s.q, s.qd); a = ca.jtimes(v, s.q, s.qd) + ca.jtimes(v, s.qd, qdd)
    om = s.omega[body][2]; al = ca.jtimes(om, s.q, s.qd) + ca.jtimes(om, s.qd, qdd)
    return ca.Function("k", [s.q, s.qd, qdd], [b.x, v, a, om, al])


# ================================================================ 1. four-bar, loop closed by hand
FB = dict(r=0.1, l=0.35, c=0.25, d=0.3, m1=0.5, m2=0.4, m3=0.5, T=0.6)


def fb_assembly(th, lib=np):
    p = FB
    A = (p["r"] * lib.cos(th), p["r"] * lib.sin(th))
    ex, ey = p["d"] - A[0], -A[1]; e = lib.sqrt(ex ** 2 + ey ** 2)
    a = (p["l"] ** 2 - p["c"] ** 2 + e ** 2) / (2 * e); h = lib.sqrt(p["l"] ** 2 - a ** 2)
    Bx = A[0] + a * ex / e - h * ey / e; By = A[1] + a * ey / e + h * ex / e
    return A, (Bx, By)


def fourbar():
    import ocp_constraints as oc
    p = FB
    model = oc.Model("four_bar", gravity=tuple(G))
    crank = model.add_body("crank", p["m1"], rod(p["m1"], p["r"]), rotation="321")
    coup = model.add_body("coupler", p["m2"], rod(p["m2"], p["l"]), rotation="321")
    rock = model.add_body("rocker", p["m3"], rod(p["m3"], p["c"]), rotation="321")
    oc.joints.revolute(model, "O", crank.point("O", (-p["r"] / 2, 0, 0)), axis=(0, 0, 1), anchor=(0, 0, 0))
    oc.joints.revolute(model, "A", coup.point("A", (-p["l"] / 2, 0, 0)), axis=(0, 0, 1),
                       other=crank.point("A", (p["r"] / 2, 0, 0)))
    oc.joints.revolute(model, "D", rock.point("D", (-p["c"] / 2, 0, 0)), axis=(0, 0, 1), anchor=(p["d"], 0, 0))
    Bc, Br = coup.point("B", (p["l"] / 2, 0, 0)), rock.point("B", (p["c"] / 2, 0, 0))
    for k in range(2):
        E = ca.DM.eye(3)[:, k]
        model.add_constraint(f"B.v{k + 1}", ca.dot(E, Bc.v) - ca.dot(E, Br.v), joint="B",
                             position=Bc.position[k] - Br.position[k])
    tau = model.add_input("motor")
    model.add_torque("motor", crank, ca.vertcat(0, 0, tau))
    ocp = oc.OptimalControlProblem(model, t_final=p["T"])
    ocp.initial({"crank.psi": 0.0, "crank.omega_z": 0.0})
    ocp.final({"crank.psi": math.pi, "crank.omega_z": 0.0})
    ocp.minimize_effort()
    th = lambda t: math.pi * np.asarray(t) / p["T"]
    def geo(t):
        A, Bp = fb_assembly(th(t)); return np.array(A), np.array(Bp)
    ocp.set_guess("crank.psi", th)
    ocp.set_guess("crank.x", lambda t: geo(t)[0][0] / 2); ocp.set_guess("crank.y", lambda t: geo(t)[0][1] / 2)
    ocp.set_guess("coupler.x", lambda t: (geo(t)[0][0] + geo(t)[1][0]) / 2)
    ocp.set_guess("coupler.y", lambda t: (geo(t)[0][1] + geo(t)[1][1]) / 2)
    ocp.set_guess("coupler.psi", lambda t: np.arctan2(geo(t)[1][1] - geo(t)[0][1], geo(t)[1][0] - geo(t)[0][0]))
    ocp.set_guess("rocker.x", lambda t: (p["d"] + geo(t)[1][0]) / 2); ocp.set_guess("rocker.y", lambda t: geo(t)[1][1] / 2)
    ocp.set_guess("rocker.psi", lambda t: np.arctan2(geo(t)[1][1], geo(t)[1][0] - p["d"]))
    return ocp


def fb_system():
    p = FB
    q, w = ca.SX.sym("q", 1), ca.SX.sym("w", 1)
    A, Bp = fb_assembly(q[0], ca)
    A = ca.vertcat(A[0], A[1], 0); Bv = ca.vertcat(Bp[0], Bp[1], 0); D = ca.DM([p["d"], 0, 0])
    beta = ca.atan2(Bv[1] - A[1], Bv[0] - A[0]); gam = ca.atan2(Bv[1], Bv[0] - p["d"])
    bodies = [R.RigidBody(p["m1"], rod(p["m1"], p["r"]), A / 2, R.rot3(q[0])),
              R.RigidBody(p["m2"], rod(p["m2"], p["l"]), (A + Bv) / 2, R.rot3(beta)),
              R.RigidBody(p["m3"], rod(p["m3"], p["c"]), (D + Bv) / 2, R.rot3(gam))]
    s0 = R.LagrangeSystem(q, w, bodies, G)
    s = R.LagrangeSystem(q, w, bodies, G, s0.torque_work(0, ca.vertcat(0, 0, w[0])))
    s.pts = ca.Function("pts", [q], [A, Bv, beta, gam])
    return s


def fb_reference(N, degree, guess=None):
    s = fb_system()
    return s, radau(s, N, FB["T"], lambda x, w, t: ca.sumsqr(w), {0: 0.0, 1: 0.0}, {0: math.pi, 1: 0.0},
                    degree=degree, guess=guess)


def cross2(r, F):
    return r[0] * F[1] - r[1] * F[0]


def fb_ref_quantities(s, ref):
    """States of every body and the joint forces (Newton-Euler on the three bodies, least squares)."""
    p = FB
    ks = [kin(s, i) for i in range(3)]
    dyn = ca.Function("qdd", [s.q, s.qd, s.w], [s.qdd])
    t, X, W = ref["t"], ref["X"], ref["W"]
    out = {k: np.zeros(len(t)) for k in ("crank.x", "crank.y", "crank.psi", "crank.vbar_x", "crank.vbar_y", "crank.omega_z",
                                         "coupler.x", "coupler.y", "coupler.psi", "coupler.vbar_x", "coupler.vbar_y",
                                         "coupler.omega_z", "rocker.x", "rocker.y", "rocker.psi", "rocker.vbar_x",
                                         "rocker.vbar_y", "rocker.omega_z",
                                         "O.v1", "O.v2", "A.v1", "A.v2", "B.v1", "B.v2", "D.v1", "D.v2")}
    I = [p["m1"] * p["r"] ** 2 / 12, p["m2"] * p["l"] ** 2 / 12, p["m3"] * p["c"] ** 2 / 12]
    m = [p["m1"], p["m2"], p["m3"]]
    resid = 0.0
    for i in range(len(t)):
        q, qd = X[0, i], X[1, i]
        w = W[0, i - 1] if i > 0 else W[0, 0]
        qdd = float(dyn(q, qd, w))
        A, Bv, beta, gam = [np.asarray(v).ravel() for v in s.pts(q)]
        psis = [q, float(beta[0]), float(gam[0])]
        kk = [[np.asarray(v).ravel() for v in k(q, qd, qdd)] for k in ks]
        for b, name in enumerate(("crank", "coupler", "rocker")):
            x, v, a, om, al = kk[b]
            out[f"{name}.x"][i], out[f"{name}.y"][i] = x[0], x[1]
            out[f"{name}.psi"][i] = psis[b]
            out[f"{name}.vbar_x"][i], out[f"{name}.vbar_y"][i] = v[0], v[1]
            out[f"{name}.omega_z"][i] = om[0]
        # unknowns FO(2) on crank, FA(2) on coupler, FB(2) on coupler, FD(2) on rocker
        O, D = np.zeros(3), np.array([p["d"], 0, 0])
        M = np.zeros((9, 8)); rhs = np.zeros(9)
        c = [kk[b][0] for b in range(3)]
        # crank: FO - FA = m a - m g ; (O-c)xFO - (A-c)xFA + tau = I al
        M[0, 0] = 1; M[0, 2] = -1; M[1, 1] = 1; M[1, 3] = -1
        rhs[0:2] = m[0] * (kk[0][2][:2] - G[:2])
        rO, rA = O - c[0], A - c[0]
        M[2, 0], M[2, 1] = -rO[1], rO[0]; M[2, 2], M[2, 3] = rA[1], -rA[0]
        rhs[2] = I[0] * kk[0][4][0] - w
        # coupler: FA + FB = m a - m g ; (A-c)xFA + (B-c)xFB = I al
        M[3, 2] = 1; M[3, 4] = 1; M[4, 3] = 1; M[4, 5] = 1
        rhs[3:5] = m[1] * (kk[1][2][:2] - G[:2])
        rA, rB = A - c[1], Bv - c[1]
        M[5, 2], M[5, 3] = -rA[1], rA[0]; M[5, 4], M[5, 5] = -rB[1], rB[0]
        rhs[5] = I[1] * kk[1][4][0]
        # rocker: FD - FB = m a - m g ; (D-c)xFD - (B-c)xFB = I al
        M[6, 6] = 1; M[6, 4] = -1; M[7, 7] = 1; M[7, 5] = -1
        rhs[6:8] = m[2] * (kk[2][2][:2] - G[:2])
        rD, rB = D - c[2], Bv - c[2]
        M[8, 6], M[8, 7] = -rD[1], rD[0]; M[8, 4], M[8, 5] = rB[1], -rB[0]
        rhs[8] = I[2] * kk[2][4][0]
        sol, *_ = np.linalg.lstsq(M, rhs, rcond=None)
        resid = max(resid, np.abs(M @ sol - rhs).max())
        for j, k in enumerate(("O.v1", "O.v2", "A.v1", "A.v2", "B.v1", "B.v2", "D.v1", "D.v2")):
            out[k][i] = sol[j]
    out["_ne_residual"] = resid
    return out


FB_STATES = [f"{b}.{c}" for b in ("crank", "coupler", "rocker") for c in ("x", "y", "psi", "vbar_x", "vbar_y", "omega_z")]
FB_MULT = ["O.v1", "O.v2", "A.v1", "A.v2", "B.v1", "B.v2", "D.v1", "D.v2"]


# ================================================================ 2. double pendulum tracking
DP = dict(m1=1.0, L1=0.6, m2=0.8, L2=0.5, T=2.0, amp=1.0, w_track=100.0, w_eff=0.01)


def dp_target(t, lib=np):
    return -math.pi / 2 + DP["amp"] * (1 - lib.cos(math.pi * t))


def dpend():
    import ocp_constraints as oc
    p = DP
    model = oc.Model("double_pendulum", gravity=tuple(G))
    a = model.add_body("a", p["m1"], rod(p["m1"], p["L1"]), rotation="321")
    b = model.add_body("b", p["m2"], rod(p["m2"], p["L2"]), rotation="321")
    oc.joints.revolute(model, "sh", a.point("S", (-p["L1"] / 2, 0, 0)), axis=(0, 0, 1), anchor=(0, 0, 0))
    oc.joints.revolute(model, "el", b.point("E", (-p["L2"] / 2, 0, 0)), axis=(0, 0, 1), other=a.point("E", (p["L1"] / 2, 0, 0)))
    t1, t2 = model.add_input("tau1"), model.add_input("tau2")
    model.add_torque("m1", a, ca.vertcat(0, 0, t1)); model.add_torque("m2", b, ca.vertcat(0, 0, t2), reaction_body=a)
    ocp = oc.OptimalControlProblem(model, t_final=p["T"])
    ocp.initial({"a.psi": -math.pi / 2, "b.psi": -math.pi / 2, "a.omega_z": 0.0, "b.omega_z": 0.0})
    ocp.track("b.psi", lambda t: dp_target(t, ca), weight=p["w_track"])
    ocp.minimize_effort(weight=p["w_eff"])
    return ocp


def dp_system():
    p = DP
    q, w = ca.SX.sym("q", 2), ca.SX.sym("w", 2)
    e = lambda a: ca.vertcat(ca.cos(a), ca.sin(a), 0)
    bodies = [R.RigidBody(p["m1"], rod(p["m1"], p["L1"]), p["L1"] / 2 * e(q[0]), R.rot3(q[0])),
              R.RigidBody(p["m2"], rod(p["m2"], p["L2"]), p["L1"] * e(q[0]) + p["L2"] / 2 * e(q[1]), R.rot3(q[1]))]
    s0 = R.LagrangeSystem(q, w, bodies, G)
    Q = s0.torque_work(0, ca.vertcat(0, 0, w[0] - w[1])) + s0.torque_work(1, ca.vertcat(0, 0, w[1]))
    return R.LagrangeSystem(q, w, bodies, G, Q)


def dp_reference(N, degree, guess=None):
    s, p = dp_system(), DP
    lag = lambda x, w, t: p["w_track"] * (x[1] - dp_target(t, ca)) ** 2 + p["w_eff"] * ca.sumsqr(w)
    return s, radau(s, N, p["T"], lag, {0: -math.pi / 2, 1: -math.pi / 2, 2: 0.0, 3: 0.0}, {}, degree=degree, guess=guess)


def generic_quantities(s, ref, names, forces):
    """names: body index -> library body name; forces(kk, w) -> dict channel -> value (Newton on bodies)."""
    ks = [kin(s, i) for i in range(len(names))]
    dyn = ca.Function("qdd", [s.q, s.qd, s.w], [s.qdd])
    n = s.q.numel(); t, X, W = ref["t"], ref["X"], ref["W"]
    out = {}
    for i in range(len(t)):
        q, qd = X[:n, i], X[n:, i]
        w = W[:, i - 1] if i > 0 else W[:, 0]
        qdd = np.asarray(dyn(q, qd, w)).ravel()
        kk = [[np.asarray(v).ravel() for v in k(q, qd, qdd)] for k in ks]
        vals = {}
        for b, name in enumerate(names):
            x, v, a, om, al = kk[b]
            vals.update({f"{name}.x": x[0], f"{name}.y": x[1], f"{name}.vbar_x": v[0], f"{name}.vbar_y": v[1],
                         f"{name}.omega_z": om[0]})
        vals.update(forces(kk, w, q))
        for k, v in vals.items():
            out.setdefault(k, np.zeros(len(t)))[i] = v
    return out


def dp_ref_quantities(s, ref):
    p = DP
    def forces(kk, w, q):
        Fel = p["m2"] * (kk[1][2] - G)
        Fsh = p["m1"] * (kk[0][2] - G) + Fel
        return {"el.v1": Fel[0], "el.v2": Fel[1], "sh.v1": Fsh[0], "sh.v2": Fsh[1], "a.psi": q[0], "b.psi": q[1],
                "el.angle": q[1] - q[0]}
    out = generic_quantities(s, ref, ["a", "b"], forces)
    out["el.rate"] = out["b.omega_z"] - out["a.omega_z"]
    return out


DP_STATES = ["a.psi", "b.psi", "a.omega_z", "b.omega_z", "el.angle", "el.rate"]
DP_MULT = ["sh.v1", "sh.v2", "el.v1", "el.v2"]


# ================================================================ 3. cart-pole, cart position bounded
CP = dict(m_cart=1.0, m_pole=0.5, L=1.0, T=2.0, xmax=None)


def cartpole_model(xmax):
    import ocp_constraints as oc
    p = CP
    model = oc.Model("cart_pole_bounded", gravity=tuple(G))
    cart = model.add_body("cart", p["m_cart"], 0.01 * np.eye(3), rotation="321")
    pole = model.add_body("pole", p["m_pole"], rod(p["m_pole"], p["L"], axis=1), rotation="321")
    oc.joints.prismatic(model, "rail", cart.com, axis=(1, 0, 0))
    oc.joints.revolute(model, "hinge", pole.point("A", (0, p["L"] / 2, 0)), axis=(0, 0, 1), other=cart.com)
    push = model.add_input("push")
    model.add_force("push", cart.com, ca.vertcat(push, 0, 0))
    ocp = oc.OptimalControlProblem(model, t_final=p["T"])
    ocp.initial({"cart.x": 0.0, "pole.psi": 0.0, "cart.vbar_x": 0.0, "pole.omega_z": 0.0})
    ocp.final({"cart.x": 0.0, "pole.psi": math.pi, "cart.vbar_x": 0.0, "pole.omega_z": 0.0})
    ocp.minimize_effort()
    if xmax is not None:
        ocp.bound("cart.x", -xmax[0], xmax[1])
    return ocp


def cp_system():
    p = CP
    q, w = ca.SX.sym("q", 2), ca.SX.sym("w", 1)
    x, th = q[0], q[1]
    Rm = R.rot3(th)
    bodies = [R.RigidBody(p["m_cart"], 0.01 * np.eye(3), ca.vertcat(x, 0, 0), ca.DM.eye(3)),
              R.RigidBody(p["m_pole"], rod(p["m_pole"], p["L"], axis=1), ca.vertcat(x, 0, 0) + Rm @ ca.DM([0, -p["L"] / 2, 0]), Rm)]
    s0 = R.LagrangeSystem(q, w, bodies, G)
    return R.LagrangeSystem(q, w, bodies, G, s0.force_work(ca.vertcat(x, 0, 0), ca.vertcat(w[0], 0, 0)))


def cp_reference(N, degree, guess=None, xmax=None, mesh=None, touch=None):
    s = cp_system()
    path = None
    if xmax is not None:
        fx = ca.Function("fx", [ca.vertcat(s.q, s.qd), s.w], [s.q[0]])
        path = [(fx, -xmax[0], xmax[1])]
    return s, radau(s, N, CP["T"], lambda x, w, t: ca.sumsqr(w), {0: 0, 1: 0, 2: 0, 3: 0}, {0: 0, 1: math.pi, 2: 0, 3: 0},
                    degree=degree, guess=guess, path=path, mesh=mesh, touch=touch)


def cp_ref_quantities(s, ref):
    p = CP
    def forces(kk, w, q):
        Fh = p["m_pole"] * (kk[1][2] - G)          # hinge on the pole
        Frail_y = p["m_cart"] * (0 - G[1]) + Fh[1]   # rail on the cart (the pole pushes the cart with -Fh)
        return {"hinge.v1": Fh[0], "hinge.v2": Fh[1], "rail.Fy": Frail_y, "cart.xq": q[0], "pole.psi": q[1]}
    return generic_quantities(s, ref, ["cart", "pole"], forces)


CP_STATES = ["cart.x", "pole.psi", "cart.vbar_x", "pole.omega_z"]
CP_MULT = ["hinge.v1", "hinge.v2", "rail.Fy"]


# ================================================================ 4. one-link arm, free final time
ARM = dict(m=1.0, L=1.0, tau_max=8.0, w_eff=0.01, Tb=(0.2, 5.0), T0=1.5)


def arm():
    import ocp_constraints as oc
    p = ARM
    model = oc.Model("one_link", gravity=tuple(G))
    r = model.add_body("rod", p["m"], rod(p["m"], p["L"]), rotation="321")
    oc.joints.revolute(model, "hinge", r.point("P", (-p["L"] / 2, 0, 0)), axis=(0, 0, 1), anchor=(0, 0, 0))
    tau = model.add_input("tau")
    model.add_torque("motor", r, ca.vertcat(0, 0, tau))
    ocp = oc.OptimalControlProblem(model, t_final=p["T0"], t_final_bounds=p["Tb"])
    ocp.initial({"rod.psi": -math.pi / 2, "rod.omega_z": 0.0})
    ocp.final({"rod.psi": math.pi / 2, "rod.omega_z": 0.0})
    ocp.bound("tau", -p["tau_max"], p["tau_max"])
    ocp.minimize_final_time()
    ocp.minimize_effort(weight=p["w_eff"])
    return ocp


def arm_system():
    p = ARM
    q, w = ca.SX.sym("q", 1), ca.SX.sym("w", 1)
    bodies = [R.RigidBody(p["m"], rod(p["m"], p["L"]), p["L"] / 2 * ca.vertcat(ca.cos(q[0]), ca.sin(q[0]), 0), R.rot3(q[0]))]
    s0 = R.LagrangeSystem(q, w, bodies, G)
    return R.LagrangeSystem(q, w, bodies, G, s0.torque_work(0, ca.vertcat(0, 0, w[0])))


def arm_reference(N, degree, guess=None, mesh=None, phases=None, pins=None):
    s, p = arm_system(), ARM
    return s, radau(s, N, p["T0"], lambda x, w, t: p["w_eff"] * ca.sumsqr(w), {0: -math.pi / 2, 1: 0.0},
                    {0: math.pi / 2, 1: 0.0}, degree=degree, input_bounds=(-p["tau_max"], p["tau_max"]),
                    free_time=p["Tb"], time_weight=1.0, guess=guess, mesh=mesh, phases=phases, pins=pins)


def arm_ref_quantities(s, ref):
    p = ARM
    def forces(kk, w, q):
        F = p["m"] * (kk[0][2] - G)
        return {"hinge.v1": F[0], "hinge.v2": F[1], "rod.psi": q[0]}
    return generic_quantities(s, ref, ["rod"], forces)


ARM_STATES = ["rod.psi", "rod.omega_z"]
ARM_MULT = ["hinge.v1", "hinge.v2"]


# ================================================================ library-side readings
def lib_values(sol, problem, t):
    """The library's values of the compared quantities at times t (s), via sol.interpolate."""
    I = lambda n: np.asarray(sol.interpolate(n, t), float)
    out = {}
    if problem == "fourbar":
        for n in FB_STATES:
            out[n] = I(n)
        for n in FB_MULT:
            out[n] = I(n + ".lambda")
        extra = ["O.v3", "O.w1", "O.w2", "A.v3", "A.w1", "A.w2", "D.v3", "D.w1", "D.w2"]
    elif problem == "dpend":
        for n in ("a.psi", "b.psi", "a.omega_z", "b.omega_z"):
            out[n] = I(n)
        out["el.angle"] = out["b.psi"] - out["a.psi"]; out["el.rate"] = out["b.omega_z"] - out["a.omega_z"]
        for n in DP_MULT:
            out[n] = I(n + ".lambda")
        extra = ["sh.v3", "sh.w1", "sh.w2", "el.v3", "el.w1", "el.w2"]
    elif problem == "cartpole":
        for n in CP_STATES:
            out[n] = I(n)
        out["hinge.v1"], out["hinge.v2"] = I("hinge.v1.lambda"), I("hinge.v2.lambda")
        out["rail.Fy"] = RAIL_SIGN[0] * I(RAIL_SIGN[1])
        extra = [c for c in ("hinge.v3", "hinge.w1", "hinge.w2", "rail.n1", "rail.n2", "rail.w1", "rail.w2", "rail.w3")
                 if c != RAIL_SIGN[1][:-7]]
    else:
        for n in ARM_STATES:
            out[n] = I(n)
        out["hinge.v1"], out["hinge.v2"] = I("hinge.v1.lambda"), I("hinge.v2.lambda")
        extra = ["hinge.v3", "hinge.w1", "hinge.w2"]
    for c in extra:
        out["zero:" + c] = I(c + ".lambda")
    return out


RAIL_SIGN = (1.0, "rail.n1.lambda")   # set after reading describe(): which rail multiplier is the E2 force on the cart

SPEC = {"fourbar": (fourbar, FB_STATES, FB_MULT), "dpend": (dpend, DP_STATES, DP_MULT),
        "cartpole": (None, CP_STATES, CP_MULT), "arm": (arm, ARM_STATES, ARM_MULT)}


def build(problem):
    if problem == "cartpole":
        xm = json.load(open(os.path.join(HERE, "cp_bound.json")))["xmax"]
        return cartpole_model(tuple(xm))
    return SPEC[problem][0]()


def errors(sol, problem, ref):
    """True errors at the reference's points (t = 0 left out for multipliers). Free time: same fraction of T."""
    T_lib = float(sol.t_final) if hasattr(sol, "t_final") else float(np.asarray(sol.t)[-1])
    frac = ref["frac"]
    t = np.clip(frac * T_lib, 0, T_lib)
    lib = lib_values(sol, problem, t)
    _, states, mult = SPEC[problem]
    out = {"states": 0.0, "multipliers": 0.0}
    where = {}
    for n in states:
        d = lib[n] - ref["q"][n]
        if n.endswith("psi") or n == "el.angle":
            d = (d + np.pi) % (2 * np.pi) - np.pi
        k = int(np.argmax(np.abs(d)))
        if abs(d[k]) > out["states"]:
            out["states"], where["states"] = float(abs(d[k])), (float(t[k]), n)
    scale = float(sol.mesh_refinement["history"][-1]["load_scale"])
    ref_peak = max(float(np.abs(ref["q"][n][1:]).max()) for n in mult)
    for n in mult + [k for k in lib if k.startswith("zero:")]:
        r = ref["q"][n] if not n.startswith("zero:") else 0.0
        d = np.abs(lib[n] - r)[1:] / scale
        k = int(np.argmax(d))
        if d[k] > out["multipliers"]:
            out["multipliers"], where["multipliers"] = float(d[k]), (float(t[k + 1]), n)
    out["where"] = where
    out["load_scale"] = scale
    out["ref_peak_load"] = ref_peak
    out["T_lib"] = T_lib
    return out


# ================================================================ commands
def load_ref(problem):
    z = np.load(os.path.join(HERE, f"ref_{problem}.npz"), allow_pickle=True)
    return z["ref"].item()


def cmd_run(problem, tol):
    import ocp_constraints as oc
    ocp = build(problem)
    c0, w0 = time.process_time(), time.perf_counter()
    try:
        sol = ocp.solve(tolerance=float(tol))
    except Exception as exc:   # noqa
        print(json.dumps({"problem": problem, "tol": tol, "crash": f"{type(exc).__name__}: {str(exc)[:400]}",
                          "cpu": time.process_time() - c0}))
        return
    cpu, wall = time.process_time() - c0, time.perf_counter() - w0
    mr = sol.mesh_refinement
    ref = load_ref(problem)
    e = errors(sol, problem, ref)
    est = {k: (float(v) if v is not None else None) for k, v in (mr.get("estimate") or {}).items()}
    rec = {"problem": problem, "tol": tol, "met": bool(mr.get("met")), "message": str(mr.get("message")),
           "cpu": cpu, "wall": wall, "points": int(sol.transcription.scheme.point_count),
           "refinements": mr.get("refinements"), "estimate": est, "true": e,
           "ratio": {k: (e[k] / est[k] if est.get(k) else None) for k in ("states", "multipliers")},
           "objective": float(sol.objective), "objective_ref": ref["objective"], "status": sol.status,
           "coordinates": mr.get("coordinates"), "ref_accuracy": ref["accuracy"], "T_ref": ref["T"],
           "worst": mr.get("worst")}
    if problem == "cartpole":
        xm = json.load(open(os.path.join(HERE, "cp_bound.json")))["xmax"]
        tt = np.linspace(0, CP["T"], 20001)
        x = np.asarray(sol.interpolate("cart.x", tt)); xs = np.asarray(sol.sample("cart.x"))
        rec["bound"] = {"xmax": xm, "max_x_interp": float(x.max()), "min_x_interp": float(x.min()),
                        "max_x_points": float(xs.max()), "min_x_points": float(xs.min())}
        # error near the contact arc(s) of the reference: where the reference is within 1e-6 of the bound
        qx = ref["q"]["cart.x"]; onb = (qx > xm[1] - 1e-6) | (qx < -xm[0] + 1e-6)
        if onb.any():
            tr = ref["t"][onb]; lo, hi = tr.min() - 0.05, tr.max() + 0.05
            win = (ref["t"] >= lo) & (ref["t"] <= hi)
            lib = lib_values(sol, problem, ref["t"])
            rec["contact"] = {"ref_arc": [float(tr.min()), float(tr.max())],
                              "state_err_near": max(float(np.abs(lib[n] - ref["q"][n])[win].max()) for n in CP_STATES),
                              "mult_err_near": max(float(np.abs(lib[n] - ref["q"][n])[win & (ref["t"] > 0)].max())
                                                   for n in CP_MULT) / e["load_scale"]}
    print(json.dumps(rec, default=str))


def cmd_all(problems):
    for p in problems:
        for tol in TOLS:
            cap = lambda: resource.setrlimit(resource.RLIMIT_CPU, (120, 125))
            c0 = time.time()
            try:
                out = subprocess.run([sys.executable, __file__, "run", p, tol], capture_output=True, text=True,
                                     timeout=150, preexec_fn=cap)
                line = (out.stdout.strip().splitlines() or [""])[-1]
                try:
                    rec = json.loads(line)
                except json.JSONDecodeError:
                    rec = {"problem": p, "tol": tol, "crash": f"exit {out.returncode}: {out.stderr.strip()[-400:]}"}
            except subprocess.TimeoutExpired:
                rec = {"problem": p, "tol": tol, "crash": "wall timeout 150 s"}
            rec["wall_total"] = time.time() - c0
            with open(os.path.join(HERE, "results.jsonl"), "a") as fh:
                fh.write(json.dumps(rec, default=str) + "\n")
            print(json.dumps(rec, default=str)[:600], flush=True)


if __name__ == "__main__":
    cmd = sys.argv[1]
    if cmd == "run":
        cmd_run(sys.argv[2], sys.argv[3])
    elif cmd == "all":
        cmd_all(sys.argv[2:])
