"""Independent references for newcomer check 7, without ocp_constraints' transcription or equations.

Both problems are the planar two-link arm (link 1: L1, m1; link 2: L2, m2; slender rods, centres at mid-length) in
minimal joint coordinates q = (q1, q2) (q2 relative, the elbow), Lagrange's equations from the kinetic and potential
energy (tests/newcomer_reference.py's LagrangeSystem: energies only), generalized forces from the motors' virtual
work (shoulder motor on link 1, elbow motor on link 2 with its reaction on link 1). Joint forces by Newton-Euler per
link: F_E = m2 (a2 - g) (on link 2 at the elbow), F_O = m1 (a1 - g) + F_E (on link 1 at the shoulder), fixed basis.
models.py is read for its parameter dictionaries only; a coarse library solve is the initial guess only.
  urdf_arm   min int tau1^2 + tau2^2, |tau1| <= tau1_max: arcs found on a uniform mesh, then phases (free / arc ...)
             with the junction times as NLP variables and tau1 continuous at each junction.
  load_arm   min int tau1^2 + tau2^2 + w_load |F_E|^2 (the elbow pin's force, Newton-Euler), smooth.
Radau IIA of degree DREF (7) on NREF and 2 NREF intervals, plain CasADi Opti, IPOPT tol 1e-12. The functions
transcribe / evaluate / find_phases / main are scripts/refinement_newcomer6/ref.py's, the bound on one input (uidx).

    python ref.py PROBLEM        # writes ref_PROBLEM.npz, prints the coarse-vs-fine difference
Env: NREF (default 40), DREF (7), GUESS_MESH ("5,40"; "default": the library's solve(tolerance=1e-3) from its default
start), JUNCTION_CONT ("1"), OUT (file name ref_OUT.npz, default the problem).
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


PLANAR_ZEROS = ["z", "theta", "phi", "vbar_z", "omega_x", "omega_y"]
QUAT_ZEROS = ["z", "qx", "qy", "vbar_z", "omega_x", "omega_y"]


def system(P):
    t = ca.SX.sym("t")
    base, p, _kw = M.variant(P)
    L1, m1, L2, m2 = p["L1"], p["m1"], p["L2"], p["m2"]
    q, w = ca.SX.sym("q", 2), ca.SX.sym("w", 2)
    a1, a12 = q[0], q[0] + q[1]
    G1 = L1 / 2 * e(a1); G2 = L1 * e(a1) + L2 / 2 * e(a12)
    bodies = [R.RigidBody(m1, rodJ(m1, L1), G1, R.rot3(a1)), R.RigidBody(m2, rodJ(m2, L2), G2, R.rot3(a12))]
    Gv = np.array([0.0, -G, 0.0])
    s0 = R.LagrangeSystem(q, w, bodies, Gv)
    z = lambda v: ca.vertcat(0, 0, v)
    Q = s0.torque_work(0, z(w[0])) + s0.torque_work(1, z(w[1])) - s0.torque_work(0, z(w[1]))
    s = R.LagrangeSystem(q, w, bodies, Gv, Q)
    x = ca.vertcat(q, s.qd); xdot = ca.vertcat(s.qd, s.qdd)
    acc = lambda ex: d_dt(d_dt(ex, x, xdot), x, xdot)
    g3 = ca.DM(Gv)
    FE = m2 * (acc(G2) - g3)            # on link 2 at the elbow
    FO = m1 * (acc(G1) - g3) + FE       # on link 1 at the shoulder
    loads = {"shoulder.v1": FO[0], "shoulder.v2": FO[1], "elbow.v1": FE[0], "elbow.v2": FE[1]}
    zeros = [f"{j}.{k}" for j in ("shoulder", "elbow") for k in ("v3", "w1", "w2")]
    states = {}
    for nm, c, ang in (("link1", G1, a1), ("link2", G2, a12)):
        v = d_dt(c, x, xdot)
        states.update({f"{nm}.x": c[0], f"{nm}.y": c[1], f"{nm}.vbar_x": v[0], f"{nm}.vbar_y": v[1],
                       f"{nm}.omega_z": d_dt(ang, x, xdot)})
        if base == "urdf_arm":
            states.update({f"{nm}.qw": ca.cos(ang / 2), f"{nm}.qz": ca.sin(ang / 2)})
        else:
            states[f"{nm}.psi"] = ang
    if base == "urdf_arm":
        zero_states = [f"{nm}.{k}" for nm in ("link1", "link2") for k in QUAT_ZEROS]
        angles, ubound = [], p["tau1_max"]
        lag = ca.sumsqr(w)
        unames = ("shoulder.tau", "elbow.tau")

        def angle(sol, nm, tt):
            return 2 * np.arctan2(sol.interpolate(f"{nm}.qz", tt), sol.interpolate(f"{nm}.qw", tt))
    else:
        zero_states = [f"{nm}.{k}" for nm in ("link1", "link2") for k in PLANAR_ZEROS]
        angles, ubound = ["link1.psi", "link2.psi"], None
        lag = ca.sumsqr(w) + p["w_load"] * ca.sumsqr(FE[0:2])
        unames = ("tau1", "tau2")

        def angle(sol, nm, tt):
            return np.asarray(sol.interpolate(f"{nm}.psi", tt))

    def lib_guess(sol, tt):
        A1, A12 = np.unwrap(angle(sol, "link1", tt)), np.unwrap(angle(sol, "link2", tt))
        W1, W12 = (np.asarray(sol.interpolate(f"{nm}.omega_z", tt)) for nm in ("link1", "link2"))
        return (np.vstack([A1, A12 - A1, W1, W12 - W1]),
                np.vstack([sol.interpolate(u, np.maximum(tt, 1e-9)) for u in unames]))
    (q10, q20), (q1f, q2f) = p["q0"], p["qf"]
    return dict(x=x, w=w, t=t, xdot=xdot, lag=lag, states=states, loads=loads, zeros=zeros, zero_states=zero_states,
                initial={0: q10, 1: q20, 2: 0.0, 3: 0.0}, final={0: q1f, 1: q2f, 2: 0.0, 3: 0.0}, T=p["T"],
                ubound=ubound, uidx=0, angles=angles, lib_guess=lib_guess)


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
                ui = S["uidx"]
                if kinds[k]:
                    opti.subject_to(wk[ui] == kinds[k] * S["ubound"])
                else:
                    opti.subject_to(opti.bounded(-S["ubound"], wk[ui], S["ubound"]))
    if phases and os.environ.get("JUNCTION_CONT", "1") == "1":
        # the input is continuous at a junction (it minimizes a strictly convex Hamiltonian, saturated): the free
        # interval next to an arc reaches the bound there (its polynomial through its collocation points)
        ext0 = np.array([np.prod([(0.0 - tau[r]) / (tau[j] - tau[r]) for r in range(degree) if r != j])
                         for j in range(degree)])
        for k in range(N):
            if kinds[k]:
                continue
            if k > 0 and kinds[k - 1]:
                opti.subject_to(sum(ext0[j] * W[S["uidx"], k * degree + j] for j in range(degree)) == kinds[k - 1] * S["ubound"])
            if k < N - 1 and kinds[k + 1]:
                opti.subject_to(W[S["uidx"], k * degree + degree - 1] == kinds[k + 1] * S["ubound"])
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
    wv = uni["W"][S["uidx"]]; tp = uni["frac"][1:]; ub = S["ubound"]
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
    gm = os.environ.get("GUESS_MESH", "5,40")
    if gm == "default":
        gdeg, gN = "default start", "solve(tolerance=1e-3)"
        lib = build().solve(tolerance=1e-3)
    else:
        gdeg, gN = (int(v) for v in gm.split(","))
        lib = build().solve(oc.Radau(gN, degree=gdeg))
    print(f"library Radau {gdeg} x {gN} (the guess only): {lib.status} objective {lib.objective:.10g} cpu {time.process_time() - c0:.1f}")
    guess_lib = lambda frac: S["lib_guess"](lib, frac * S["T"])
    deg = int(os.environ.get("DREF", 7)); N = int(os.environ.get("NREF", 40))
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
    np.savez(os.path.join(HERE, f"ref_{os.environ.get('OUT', P)}.npz"), ref=np.array(fine, dtype=object))


if __name__ == "__main__":
    main(sys.argv[1])
