"""Independent references for newcomer check 6, without ocp_constraints' transcription or equations.

Each problem's dynamics are derived here in its own coordinates (models.py is read for its parameter dictionaries,
and a coarse library solve is used as the initial guess only):
  fourbar  Lagrange in the crank angle (tests/newcomer_reference.py's energy helpers), the loop closed in closed
           form (circle intersection for pin B); pin forces by Newton-Euler on each link (8 x 8 linear solve).
  sph      Lagrange in 3-2-1 Euler angles (theta stays within +-0.6 of 0); the socket force m (a_G - g).
  sleigh   Chaplygin sleigh in (x_C, y_C, psi, u, omega) by Newton-Euler with the blade force lambda e2 at C.
  track    Lagrange in the rod angle; hinge force m (a_G - g); |tau| <= tau_max, arcs found on a uniform mesh,
           then solved in phases (free / arc at +-tau_max / free ...) whose junction times are NLP variables.
Radau IIA collocation of degree DREF (7) on NREF and 2 NREF intervals, plain CasADi Opti, IPOPT tol 1e-12.

    python ref.py PROBLEM        # writes ref_PROBLEM.npz, prints the coarse-vs-fine difference
Env: NREF (default 60), DREF (7), GUESS_MESH ("degree,N" of the library's fixed-mesh guess solve, "5,40"), JUNCTION_CONT
("1": the input continuous at each junction, the default; "0": junction times free only).
"""
import importlib.util, json, math, os, sys, time
import casadi as ca
import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
_spec = importlib.util.spec_from_file_location("newcomer_reference", os.path.join(HERE, "..", "..", "tests", "newcomer_reference.py"))
R = importlib.util.module_from_spec(_spec); sys.modules["newcomer_reference"] = R; _spec.loader.exec_module(R)
sys.path.insert(0, HERE)
import models as M

G = M.G


def e(a):
    return ca.vertcat(ca.cos(a), ca.sin(a), 0)


def rodJ(m, L):
    return np.diag([1e-4, m * L ** 2 / 12, m * L ** 2 / 12])


def d_dt(expr, x, xdot):
    return ca.jtimes(expr, x, xdot)


def cross2(r, f):
    return r[0] * f[1] - r[1] * f[0]


def planar_body(name, c, ang, x, xdot):
    v = d_dt(c, x, xdot)
    return {f"{name}.x": c[0], f"{name}.y": c[1], f"{name}.psi": ang, f"{name}.vbar_x": v[0], f"{name}.vbar_y": v[1],
            f"{name}.omega_z": d_dt(ang, x, xdot)}


PLANAR_ZEROS = ["z", "theta", "phi", "vbar_z", "omega_x", "omega_y"]


def system(P):
    """dict: x, w, t (SX), xdot(x, w, t), lag, states (library name -> expr of x), loads (library multiplier name ->
    expr of x, w, t), zeros (multipliers that vanish), zero_states, initial/final {index: value}, T, ubound
    (input bound, for arcs) or None, angles (names compared modulo 2 pi), lib_guess(sol, t) -> (X, W)."""
    t = ca.SX.sym("t")
    P_name = P
    P, p, _kw = M.variant(P)
    if P == "fourbar":
        a, b, c, d = p["a"], p["b"], p["c"], p["d"]
        q, w = ca.SX.sym("q", 1), ca.SX.sym("w", 1)
        th = q[0]
        A = a * e(th); D = ca.vertcat(d, 0, 0)
        dl = D - A; L = ca.norm_2(dl); u = dl / L
        along = (b ** 2 - c ** 2 + L ** 2) / (2 * L); h = ca.sqrt(b ** 2 - along ** 2)
        B = A + along * u + h * ca.vertcat(-u[1], u[0], 0)
        beta = ca.atan2(B[1] - A[1], B[0] - A[0]); gam = ca.atan2(B[1] - D[1], B[0] - D[0])
        m1, m2, m3 = p["rho"] * a, p["rho"] * b, p["rho"] * c
        G1, G2, G3 = A / 2, (A + B) / 2, (D + B) / 2
        bodies = [R.RigidBody(m1, rodJ(m1, a), G1, R.rot3(th)), R.RigidBody(m2, rodJ(m2, b), G2, R.rot3(beta)),
                  R.RigidBody(m3, rodJ(m3, c), G3, R.rot3(gam))]
        Gv = np.array([0.0, -G, 0.0])
        s0 = R.LagrangeSystem(q, w, bodies, Gv)
        s = R.LagrangeSystem(q, w, bodies, Gv, s0.torque_work(0, ca.vertcat(0, 0, w[0])))
        x = ca.vertcat(q, s.qd); xdot = ca.vertcat(s.qd, s.qdd)
        acc = lambda ex: d_dt(d_dt(ex, x, xdot), x, xdot)
        a1, a2, a3 = acc(G1), acc(G2), acc(G3); al2, al3 = acc(beta), acc(gam)
        I2, I3 = m2 * b ** 2 / 12, m3 * c ** 2 / 12
        # unknowns: F_O (on crank at O), F_A (on coupler at A), F_B (on rocker at B), F_D (on rocker at D)
        U = ca.SX.sym("U", 8); FO, FA, FB, FD = U[0:2], U[2:4], U[4:6], U[6:8]
        g2 = ca.vertcat(0, -G)
        eqs = ca.vertcat(m1 * a1[0:2] - (FO - FA + m1 * g2),
                         m2 * a2[0:2] - (FA - FB + m2 * g2),
                         I2 * al2 - (cross2(A - G2, FA) + cross2(B - G2, -FB)),
                         m3 * a3[0:2] - (FD + FB + m3 * g2),
                         I3 * al3 - (cross2(D - G3, FD) + cross2(B - G3, FB)))
        Amat = ca.jacobian(eqs, U); rhs = -ca.substitute(eqs, U, ca.DM.zeros(8))
        sol = ca.solve(Amat, rhs)
        FO, FA, FB, FD = sol[0:2], sol[2:4], sol[4:6], sol[6:8]
        ub1, ub2 = ca.vertcat(ca.cos(beta), ca.sin(beta)), ca.vertcat(-ca.sin(beta), ca.cos(beta))
        loads = {"O.v1": FO[0], "O.v2": FO[1], "A.v1": FA[0], "A.v2": FA[1], "D.v1": FD[0], "D.v2": FD[1],
                 "B.n1": ca.dot(FB, ub1), "B.n2": ca.dot(FB, ub2)}
        zeros = [f"{j}.{k}" for j in "OAD" for k in ("v3", "w1", "w2")]
        states = {}
        for nm, cc, ang in (("crank", G1, th), ("coupler", G2, beta), ("rocker", G3, gam)):
            states.update(planar_body(nm, cc, ang, x, xdot))
        lag = w[0] ** 2 + p["w_load"] * ca.sumsqr(FO)

        def lib_guess(sol, tt):
            return (np.vstack([sol.interpolate("crank.psi", tt), sol.interpolate("crank.omega_z", tt)]),
                    np.atleast_2d(sol.interpolate("tau", np.maximum(tt, 1e-9))))
        return dict(x=x, w=w, t=t, xdot=xdot, lag=lag, states=states, loads=loads, zeros=zeros,
                    zero_states=[f"{bn}.{k}" for bn in ("crank", "coupler", "rocker") for k in PLANAR_ZEROS],
                    initial={0: 0.0, 1: 0.0}, final={0: p["theta_f"], 1: 0.0}, T=p["T"], ubound=None,
                    angles=["crank.psi", "coupler.psi", "rocker.psi"], lib_guess=lib_guess)
    if P == "sph":
        m, L = p["m"], p["L"]
        q, w = ca.SX.sym("q", 3), ca.SX.sym("w", 3)
        Rm = R.rot3(q[0]) @ R.rot2(q[1]) @ R.rot1(q[2])
        Gc = -Rm @ ca.DM([0, 0, L / 2])
        J = np.diag([m * L ** 2 / 12, m * L ** 2 / 12, 0.01])
        bodies = [R.RigidBody(m, J, Gc, Rm)]
        Gv = np.array([0.0, 0.0, -G])
        s0 = R.LagrangeSystem(q, w, bodies, Gv)
        s = R.LagrangeSystem(q, w, bodies, Gv, s0.torque_work(0, w))
        x = ca.vertcat(q, s.qd); xdot = ca.vertcat(s.qd, s.qdd)
        vG = d_dt(Gc, x, xdot); aG = d_dt(vG, x, xdot)
        F = m * aG - m * ca.DM(Gv)
        om = s.omega[0]
        # the quaternion (w, x, y, z) of R3 R2 R1 (half-angle formula), qw > 0 along the motion
        hp, ht, hf = q[0] / 2, q[1] / 2, q[2] / 2
        quat = ca.vertcat(ca.cos(hf) * ca.cos(ht) * ca.cos(hp) + ca.sin(hf) * ca.sin(ht) * ca.sin(hp),
                          ca.sin(hf) * ca.cos(ht) * ca.cos(hp) - ca.cos(hf) * ca.sin(ht) * ca.sin(hp),
                          ca.cos(hf) * ca.sin(ht) * ca.cos(hp) + ca.sin(hf) * ca.cos(ht) * ca.sin(hp),
                          ca.cos(hf) * ca.cos(ht) * ca.sin(hp) - ca.sin(hf) * ca.sin(ht) * ca.cos(hp))
        states = {"bob.x": Gc[0], "bob.y": Gc[1], "bob.z": Gc[2], "bob.vbar_x": vG[0], "bob.vbar_y": vG[1],
                  "bob.vbar_z": vG[2], "bob.omega_x": om[0], "bob.omega_y": om[1], "bob.omega_z": om[2],
                  "bob.qw": quat[0], "bob.qx": quat[1], "bob.qy": quat[2], "bob.qz": quat[3]}
        loads = {"socket.v1": F[0], "socket.v2": F[1], "socket.v3": F[2]}
        f = p["final_321"]

        def lib_guess(sol, tt):
            qw, qx, qy, qz = (np.asarray(sol.interpolate(f"bob.q{k}", tt)) for k in "wxyz")
            n = np.sqrt(qw ** 2 + qx ** 2 + qy ** 2 + qz ** 2); qw, qx, qy, qz = qw / n, qx / n, qy / n, qz / n
            R00 = 1 - 2 * (qy ** 2 + qz ** 2); R10 = 2 * (qx * qy + qz * qw); R20 = 2 * (qx * qz - qy * qw)
            R21 = 2 * (qy * qz + qx * qw); R22 = 1 - 2 * (qx ** 2 + qy ** 2)
            ang = np.unwrap(np.vstack([np.arctan2(R10, R00), -np.arcsin(np.clip(R20, -1, 1)), np.arctan2(R21, R22)]), axis=1)
            rates = np.vstack([np.gradient(a_, tt) for a_ in ang])
            return np.vstack([ang, rates]), np.vstack([sol.interpolate(f"t{k}", np.maximum(tt, 1e-9)) for k in "xyz"])
        if p.get("qsign", 1) == -1:
            # the final pose as -q: the Euler angles end 2 pi further on one of them (which one: the library's path)
            import ocp_constraints as oc
            g = M.build(P_name).solve(oc.Radau(40, degree=5))
            end = lib_guess(g, np.linspace(0, p["T"], 401))[0][:3, -1]
            f = [fv + 2 * math.pi * round((e_ - fv) / (2 * math.pi)) for fv, e_ in zip(f, end)]
            print("sph_negq: final Euler angles", f)
        return dict(x=x, w=w, t=t, xdot=xdot, lag=ca.sumsqr(w), states=states, loads=loads, zeros=[], zero_states=[],
                    initial={0: 0, 1: 0, 2: 0, 3: 0, 4: 0, 5: 0}, final={0: f[0], 1: f[1], 2: f[2], 3: 0, 4: 0, 5: 0},
                    T=p["T"], ubound=None, angles=[], lib_guess=lib_guess)
    if P == "sleigh":
        m, I, a = p["m"], p["I"], p["a"]
        x, w = ca.SX.sym("x", 5), ca.SX.sym("w", 2)     # x_C, y_C, psi, u (forward speed of C), omega; F, tau
        psi, u, om = x[2], x[3], x[4]
        omd = (w[1] - m * a * u * om) / (I + m * a ** 2)
        ud = w[0] / m + a * om ** 2
        xdot = ca.vertcat(u * ca.cos(psi), u * ca.sin(psi), om, ud, omd)
        lam = m * (u * om + a * omd)                     # lateral force on the sleigh at C, along e2
        e1, e2 = ca.vertcat(ca.cos(psi), ca.sin(psi)), ca.vertcat(-ca.sin(psi), ca.cos(psi))
        Gp = x[0:2] + a * e1; vG = u * e1 + a * om * e2
        states = {"sleigh.x": Gp[0], "sleigh.y": Gp[1], "sleigh.psi": psi, "sleigh.vbar_x": vG[0],
                  "sleigh.vbar_y": vG[1], "sleigh.omega_z": om}
        x1, y1, psi1 = p["target"]

        def lib_guess(sol, tt):
            gx, gy, ps = (np.asarray(sol.interpolate(f"sleigh.{k}", tt)) for k in ("x", "y", "psi"))
            vx, vy, omz = (np.asarray(sol.interpolate(f"sleigh.{k}", tt)) for k in ("vbar_x", "vbar_y", "omega_z"))
            X = np.vstack([gx - a * np.cos(ps), gy - a * np.sin(ps), ps, vx * np.cos(ps) + vy * np.sin(ps), omz])
            return X, np.vstack([sol.interpolate(k, np.maximum(tt, 1e-9)) for k in ("F", "tau")])
        return dict(x=x, w=w, t=t, xdot=xdot, lag=ca.sumsqr(w), states=states, loads={"knife": lam},
                    zeros=["floor.n", "floor.w1", "floor.w2"], zero_states=[f"sleigh.{k}" for k in PLANAR_ZEROS],
                    initial={0: -a, 1: 0.0, 2: 0.0, 3: 0.0, 4: 0.0},
                    final={0: x1 - a * math.cos(psi1), 1: y1 - a * math.sin(psi1), 2: psi1, 3: 0.0, 4: 0.0},
                    T=p["T"], ubound=None, angles=["sleigh.psi"], lib_guess=lib_guess)
    if P == "track":
        q, w = ca.SX.sym("q", 1), ca.SX.sym("w", 1)
        cG = p["L"] / 2 * e(q[0])
        bodies = [R.RigidBody(p["m"], rodJ(p["m"], p["L"]), cG, R.rot3(q[0]))]
        Gv = np.array([0.0, -G, 0.0])
        s0 = R.LagrangeSystem(q, w, bodies, Gv)
        s = R.LagrangeSystem(q, w, bodies, Gv, s0.torque_work(0, ca.vertcat(0, 0, w[0])))
        x = ca.vertcat(q, s.qd); xdot = ca.vertcat(s.qd, s.qdd)
        F = p["m"] * (d_dt(d_dt(cG, x, xdot), x, xdot) - ca.DM(Gv))
        ref = -math.pi / 2 + p["A"] * ca.sin(p["w"] * t)
        lag = p["W"] * (q[0] - ref) ** 2 + p["w_eff"] * w[0] ** 2

        def lib_guess(sol, tt):
            return (np.vstack([sol.interpolate("rod.psi", tt), sol.interpolate("rod.omega_z", tt)]),
                    np.atleast_2d(sol.interpolate("tau", np.maximum(tt, 1e-9))))
        return dict(x=x, w=w, t=t, xdot=xdot, lag=lag, states=planar_body("rod", cG, q[0], x, xdot),
                    loads={"hinge.v1": F[0], "hinge.v2": F[1]}, zeros=["hinge.v3", "hinge.w1", "hinge.w2"],
                    zero_states=[f"rod.{k}" for k in PLANAR_ZEROS], initial={0: -math.pi / 2, 1: 0.0}, final={},
                    T=p["T"], ubound=p["tau_max"], angles=["rod.psi"], lib_guess=lib_guess)
    raise SystemExit(f"unknown problem {P}")


def transcribe(S, N, degree, guess, phases=None):
    """phases: None (one phase, uniform mesh) or a list of (start fraction guess, kind) with kind 0 (free) or +-1
    (input 0 at +-ubound); the interior phase boundaries are NLP variables, each phase gets a share of N by length."""
    x, w, t = S["x"], S["w"], S["t"]
    f = ca.Function("f", [x, w, t], [S["xdot"], S["lag"]])
    tau, C, B = R.radau_coefficients(degree)
    opti = ca.Opti()
    T = S["T"]
    if not phases:
        mesh = ca.DM(np.linspace(0, 1, N + 1)); kinds = [0] * N; jv = []
    else:
        starts = [ph[0] for ph in phases] + [1.0]
        lengths = np.diff(starts)
        counts = np.maximum(3, np.round(N * lengths / lengths.sum())).astype(int)
        jv = [opti.variable() for _ in phases[1:]]
        for v, g in zip(jv, starts[1:-1]):
            opti.set_initial(v, g)
        ends = [0.0] + jv + [1.0]
        for a_, b_ in zip(ends[:-1], ends[1:]):
            opti.subject_to(b_ - a_ >= 1e-3)
        parts, kinds = [ca.DM([0.0])], []
        for k, Nk in enumerate(counts):
            parts.append(ends[k] + (ends[k + 1] - ends[k]) * ca.DM(np.linspace(0, 1, Nk + 1)[1:]))
            kinds += [phases[k][1]] * int(Nk)
        mesh = ca.vertcat(*parts); N = int(counts.sum())
    nx, nw = x.numel(), w.numel()
    X = opti.variable(nx, N * degree + 1); W = opti.variable(nw, N * degree)
    J = 0
    for k in range(N):
        h = T * (mesh[k + 1] - mesh[k])
        cols = [X[:, k * degree + j] for j in range(degree + 1)]
        for j in range(1, degree + 1):
            xp = sum(C[r, j] * cols[r] for r in range(degree + 1))
            wk = W[:, k * degree + j - 1]
            tk = T * mesh[k] + h * tau[j - 1]
            dx, L = f(cols[j], wk, tk)
            opti.subject_to(xp == h * dx)
            J += h * B[j] * L
            if S["ubound"] is not None:
                if kinds[k]:
                    opti.subject_to(wk == kinds[k] * S["ubound"])
                else:
                    opti.subject_to(opti.bounded(-S["ubound"], wk, S["ubound"]))
    if phases and os.environ.get("JUNCTION_CONT", "1") == "1":
        # the input is continuous at a junction (it minimizes a strictly convex Hamiltonian, saturated): the free
        # interval next to an arc reaches the bound there (its polynomial through its collocation points)
        ext0 = np.array([np.prod([(0.0 - tau[r]) / (tau[j] - tau[r]) for r in range(degree) if r != j])
                         for j in range(degree)])
        for k in range(N):
            if kinds[k]:
                continue
            if k > 0 and kinds[k - 1]:
                opti.subject_to(sum(ext0[j] * W[:, k * degree + j] for j in range(degree)) == kinds[k - 1] * S["ubound"])
            if k < N - 1 and kinds[k + 1]:
                opti.subject_to(W[:, k * degree + degree - 1] == kinds[k + 1] * S["ubound"])
    for i, v in S["initial"].items():
        opti.subject_to(X[i, 0] == v)
    for i, v in S["final"].items():
        opti.subject_to(X[i, -1] == v)
    mesh_g = np.asarray(ca.evalf(ca.substitute(mesh, ca.vertcat(*jv), ca.DM([ph[0] for ph in phases[1:]])))
                        if jv else mesh).ravel()
    frac = np.concatenate([[0.0], (mesh_g[:-1, None] + np.diff(mesh_g)[:, None] * tau[None, :]).ravel()])
    gx, gw = guess(frac)
    opti.set_initial(X, gx); opti.set_initial(W, gw[:, 1:])
    opti.minimize(J)
    opti.solver("ipopt", {"print_time": False}, {"print_level": 0, "sb": "yes", "tol": 1e-12, "max_iter": 5000})
    sol = opti.solve()
    mesh_v = np.asarray(sol.value(mesh)).ravel()
    frac = np.concatenate([[0.0], (mesh_v[:-1, None] + np.diff(mesh_v)[:, None] * tau[None, :]).ravel()])
    Xv, Wv = np.atleast_2d(sol.value(X)), np.atleast_2d(sol.value(W))
    if Xv.shape[0] != nx:
        Xv = Xv.reshape(nx, -1)
    if Wv.shape[0] != nw:
        Wv = Wv.reshape(nw, -1)
    qs = ca.Function("qs", [x], [ca.vertcat(*S["states"].values())])
    ql = ca.Function("ql", [x, w, t], [ca.vertcat(*S["loads"].values())])
    st = np.asarray(qs(Xv)).reshape(len(S["states"]), -1)
    ld = np.asarray(ql(Xv[:, 1:], Wv, (frac[1:] * T)[None, :])).reshape(len(S["loads"]), -1)
    return {"objective": float(sol.value(J)), "T": T, "mesh": mesh_v, "frac": frac, "degree": degree, "tau": tau,
            "X": Xv, "W": Wv, "states": dict(zip(S["states"], st)), "loads": dict(zip(S["loads"], ld)),
            "junctions": [float(sol.value(v)) for v in jv], "iterations": int(sol.stats()["iter_count"])}


def evaluate(ref, name, fq, kind):
    """The reference's interval polynomial of a state (start and collocation nodes) or a load (collocation nodes
    only) at fractions fq of the horizon; a point on a mesh point belongs to the interval ending there."""
    mesh, d, tau = ref["mesh"], ref["degree"], ref["tau"]
    N = len(mesh) - 1
    fq = np.atleast_1d(np.asarray(fq, float))
    k = np.clip(np.searchsorted(mesh, fq, side="left") - 1, 0, N - 1)
    vals = ref["states"][name] if kind == "state" else ref["loads"][name]
    xs = np.r_[0.0, tau] if kind == "state" else np.asarray(tau)
    off = 0 if kind == "state" else 0
    out = np.zeros(len(fq))
    for i, (fv, kk) in enumerate(zip(fq, k)):
        a_, b_ = mesh[kk], mesh[kk + 1]
        ys = vals[kk * d: kk * d + d + 1] if kind == "state" else vals[kk * d: kk * d + d]
        z = (fv - a_) / (b_ - a_)
        out[i] = sum(ys[j] * np.prod([(z - xs[r]) / (xs[j] - xs[r]) for r in range(len(xs)) if r != j])
                     for j in range(len(xs)))
    return out


def find_phases(S, uni, rel=1e-7):
    """Runs of collocation points with the input on a bound -> [(start fraction, kind)], kind 0 free, +-1 arc."""
    wv = uni["W"][0]; tp = uni["frac"][1:]; ub = S["ubound"]
    kind = np.where(wv >= ub * (1 - rel), 1, np.where(wv <= -ub * (1 - rel), -1, 0))
    runs = []
    for k, tt in zip(kind, tp):
        if runs and runs[-1][0] == k:
            runs[-1][2] = tt
        else:
            runs.append([k, tt, tt])
    phases = []
    for i, (k, a_, b_) in enumerate(runs):
        if k != 0 and b_ - a_ < 0.005:        # a touch, not an arc: leave it free
            k = 0
        start = 0.0 if i == 0 else (a_ if k != 0 else runs[i - 1][2])
        if phases and phases[-1][1] == k:
            continue
        phases.append((float(start), int(k)))
    return phases, [(int(k), round(a_, 6), round(b_, 6)) for k, a_, b_ in runs if k]


def main(P):
    import ocp_constraints as oc
    S = system(P)
    build = lambda: M.build(P)
    c0 = time.process_time()
    gdeg, gN = (int(v) for v in os.environ.get("GUESS_MESH", "5,40").split(","))
    lib = build().solve(oc.Radau(gN, degree=gdeg))
    print(f"library Radau {gdeg} x {gN} (the guess only): {lib.status} objective {lib.objective:.10g} cpu {time.process_time() - c0:.1f}")
    guess_lib = lambda frac: S["lib_guess"](lib, frac * S["T"])
    deg = int(os.environ.get("DREF", 7)); N = int(os.environ.get("NREF", 60))
    phases, gfun = None, guess_lib
    if S["ubound"] is not None:
        c0 = time.process_time()
        uni = transcribe(S, 2 * N, deg, guess_lib)
        phases, raw = find_phases(S, uni)
        if all(k == 0 for _, k in phases):
            phases = None      # the bound is never active: one phase, uniform mesh
        print(f"uniform {2 * N} x {deg}: objective {uni['objective']:.12g}, cpu {time.process_time() - c0:.1f}; "
              f"active runs {raw}; phases {phases}")

        def gfun(frac, uni=uni):
            X = np.vstack([np.interp(frac, uni["frac"], r) for r in uni["X"]])
            Wg = np.vstack([np.interp(frac, uni["frac"][1:], r) for r in uni["W"]])
            return X, Wg
    refs = []
    for n in (N, 2 * N):
        c0 = time.process_time()
        r = transcribe(S, n, deg, gfun, phases=phases)
        print(f"reference N={len(r['mesh']) - 1} degree {deg}: objective {r['objective']:.14g} "
              f"junctions {np.round(r['junctions'], 9).tolist()} iterations {r['iterations']} cpu {time.process_time() - c0:.1f}")
        refs.append(r)
    coarse, fine = refs
    # coarse vs fine on a dense grid (16 points inside every coarse interval)
    mc = coarse["mesh"]
    dense = np.unique(np.concatenate([mc[:-1, None] + np.diff(mc)[:, None] * ((np.arange(16) + 0.5) / 16)[None, :]]).ravel())
    acc_s = max(float(np.abs(evaluate(fine, k, dense, "state") - evaluate(coarse, k, dense, "state")).max()) for k in S["states"])
    peak = max(float(np.abs(v).max()) for v in fine["loads"].values())
    acc_m = max(float(np.abs(evaluate(fine, k, dense, "load") - evaluate(coarse, k, dense, "load")).max()) for k in S["loads"]) / peak
    fine["accuracy"] = {"states_coarse_vs_fine": acc_s, "loads_coarse_vs_fine_rel_peak": acc_m,
                        "objective_coarse": coarse["objective"], "objective_fine": fine["objective"], "peak_load": peak,
                        "phases": phases, "junctions_coarse": coarse["junctions"], "junctions_fine": fine["junctions"],
                        "N": [len(coarse["mesh"]) - 1, len(fine["mesh"]) - 1], "degree": deg,
                        "lib_guess_objective": float(lib.objective), "guess_mesh": f"library Radau {gdeg} x {gN}"}
    print(json.dumps(fine["accuracy"], default=float))
    fine["zeros"] = S["zeros"]; fine["zero_states"] = S["zero_states"]; fine["angles"] = S["angles"]
    np.savez(os.path.join(HERE, f"ref_{P}.npz"), ref=np.array(fine, dtype=object))


if __name__ == "__main__":
    main(sys.argv[1])
