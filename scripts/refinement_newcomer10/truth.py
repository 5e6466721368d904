"""The four problems as minimal-coordinate ODEs for ``reference.Reference`` (plain CasADi; numbers from models.py,
which only holds parameters here) and the map from a reference solution to the library's names (states, multipliers,
inputs) at times t. Constraint forces by Newton-Euler on the reference motion.

    python truth.py NAME         # solve at N and 2N, print their differences (the reference's own accuracy), save
                                 # ref_NAME.npz-free pickles (ref_NAME.pkl) of the finer one
"""
from __future__ import annotations

import json
import math
import pickle
import sys
import time
from pathlib import Path

import casadi as ca
import numpy as np

from models import CHAIN, G, MINT, SLEW, STIFF, slew_final_quaternion, stiff_final_rotor, stiff_k
from reference import Reference

HERE = Path(__file__).resolve().parent


# ------------------------------------------------------------------ specs
def stiff_spec(k, N=40):
    s = STIFF
    m, L, Jr, T = s["m"], s["L"], s["J_r"], s["T"]
    r, IA = L / 2, m * L**2 / 3

    def f(x, u):
        th, w, ph, wr = x[0], x[1], x[2], x[3]
        return ca.vertcat(w, (k * (ph - th) - m * G * r * ca.sin(th)) / IA, wr, (u[0] - k * (ph - th)) / Jr)
    p1, pr1 = s["psi1"], stiff_final_rotor(k)

    def gx(t):
        sm = t / T - math.sin(2 * math.pi * t / T) / (2 * math.pi)
        dsm = (1 - math.cos(2 * math.pi * t / T)) / T
        return [p1 * sm, p1 * dsm, pr1 * sm, pr1 * dsm]
    return dict(nx=4, nu=1, f=f, L=lambda x, u: u[0] ** 2, x0=[0, 0, 0, 0], xT=[p1, 0, pr1, 0], T=T,
                phases=[dict(N=N, dur=T)], guess_x=gx, guess_u=lambda t: [0.0])


def chain_sym():
    c = CHAIN
    m, L = c["m"], c["L"]
    r, I = L / 2, m * L**2 / 12
    q = ca.SX.sym("q", 3)
    w = ca.SX.sym("w", 3)
    wd = ca.SX.sym("wd", 3)
    e = [ca.vertcat(ca.sin(q[i]), -ca.cos(q[i])) for i in range(3)]
    P = [ca.SX.zeros(2, 1), L * e[0], L * e[0] + L * e[1]]
    com = [P[i] + r * e[i] for i in range(3)]
    vel = [ca.jtimes(com[i], q, w) for i in range(3)]
    acc = [ca.jtimes(vel[i], ca.vertcat(q, w), ca.vertcat(w, wd)) for i in range(3)]
    Tk = sum(0.5 * m * ca.dot(vel[i], vel[i]) + 0.5 * I * w[i] ** 2 for i in range(3))
    V = sum(m * G * com[i][1] for i in range(3))
    Lg = Tk - V
    M = ca.hessian(Tk, w)[0]
    dLdw = ca.gradient(Lg, w)
    # d/dt dL/dw = M wd + (d(dLdw)/dq) w ; EOM: M wd = Q + dL/dq - (d dLdw/dq) w
    tau = ca.SX.sym("tau", 3)
    Q = ca.vertcat(tau[0] - tau[1], tau[1] - tau[2], tau[2])
    rhs = Q + ca.gradient(Lg, q) - ca.jacobian(dLdw, q) @ w
    wdot = ca.solve(M, rhs)
    f = ca.Function("f", [q, w, tau], [wdot])
    A = ca.Function("acc", [q, w, wd], [ca.horzcat(*acc)])          # 2 x 3: com accelerations
    Vel = ca.Function("vel", [q, w], [ca.horzcat(*vel)])
    Com = ca.Function("com", [q], [ca.horzcat(*com)])
    return f, A, Vel, Com


def chain_spec(N=20):
    c = CHAIN
    f, *_ = chain_sym()
    T, fin = c["T"], c["final"]

    def gx(t):
        sm = t / T - math.sin(2 * math.pi * t / T) / (2 * math.pi)
        dsm = (1 - math.cos(2 * math.pi * t / T)) / T
        return [v * sm for v in fin] + [v * dsm for v in fin]
    return dict(nx=6, nu=3, f=lambda x, u: ca.vertcat(x[3:6], f(x[0:3], x[3:6], u)),
                L=lambda x, u: ca.sumsqr(u), x0=[0] * 6, xT=list(fin) + [0, 0, 0], T=T,
                phases=[dict(N=N, dur=T)], guess_x=gx, guess_u=lambda t: [0.0, 0.0, 0.0])


def quat_mul(a, b):
    aw, av, bw, bv = a[0], a[1:4], b[0], b[1:4]
    return ca.vertcat(aw * bw - ca.dot(av, bv), aw * bv + bw * av + ca.cross(av, bv))


def quat_R(q):
    w, x, y, z = q[0], q[1], q[2], q[3]
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                     [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                     [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])


def slew_spec(bound=False, N=20, phased=True):
    s = SLEW
    J = ca.DM(s["J"])
    T = s["T"]
    qf = slew_final_quaternion()

    def f(x, u):
        q, wb = x[0:4], x[4:7]
        qd = 0.5 * quat_mul(q, ca.vertcat(0, wb))
        wd = (u - ca.cross(wb, J * wb)) / J
        return ca.vertcat(qd, wd)

    def gx(t):
        sm = t / T - math.sin(2 * math.pi * t / T) / (2 * math.pi)
        a = np.asarray(s["axis"], float)
        a = a / np.linalg.norm(a)
        h = s["angle"] * sm / 2
        return [math.cos(h), *(math.sin(h) * a), *(0.5 * a)]
    spec = dict(nx=7, nu=3, f=f, L=lambda x, u: ca.sumsqr(u), x0=[1, 0, 0, 0, 0, 0, 0], xT=[None] + list(qf[1:]) + [0, 0, 0],   # qw: by the norm (Radau
                # keeps |q| only to ~1e-9: all four fixed left the NLP near-degenerate, N vs 2N 1.8e-7 not converging)
               
                T=T, phases=[dict(N=N, dur=T)], guess_x=gx, guess_u=lambda t: [0.0, 0.0, 0.0])
    if bound:
        tm = s["tau_max"]
        spec["ubounds"] = ([-tm] * 3, [tm] * 3)
    if bound and phased:
        # arcs read from the uniform reference: tau1 = +max on [0, ta], tau3 = +max on [0, tb], tau2 = -max on
        # [tc, T], tau3 = -max on [td, T]; ta < tb < tc < td free junction times, the input continuous across them
        e = [lambda x, u: ca.vertcat(u[0] - tm, u[2] - tm), lambda x, u: u[2] - tm, None,
             lambda x, u: u[1] + tm, lambda x, u: ca.vertcat(u[1] + tm, u[2] + tm)]
        durs = [0.374, 0.579, 1.088, 0.296, 0.663]
        Ns = [8, 12, 20, 8, 12]
        spec["phases"] = [dict(N=n, dur=dd, eq=ee) for n, dd, ee in zip(Ns, durs, e)]
        spec["u_continuous"] = True
    return spec


def mint_force(x, u, lib=False):
    c = MINT
    m, L = c["m"], c["L"]
    r, IA = L / 2, m * L**2 / 3
    th, w = x[0], x[1]
    acc = (u[0] - m * G * r * ca.sin(th)) / IA
    ax = r * (ca.cos(th) * acc - ca.sin(th) * w**2)
    ay = r * (ca.sin(th) * acc + ca.cos(th) * w**2)
    return m * ax, m * ay + m * G


def mint_spec(N=20, phased=True):
    c = MINT
    m, L = c["m"], c["L"]
    r, IA = L / 2, m * L**2 / 3
    f = lambda x, u: ca.vertcat(x[1], (u[0] - m * G * r * ca.sin(x[0])) / IA)   # noqa: E731

    def F2(x, u):
        fx, fy = mint_force(x, u)
        return fx**2 + fy**2
    fm2 = c["f_max"] ** 2
    T = 0.644
    if phased:   # force bound held on [0, t1], free after (structure read from a library solve; checked in cmd)
        phases = [dict(N=N, dur=0.23, eq=lambda x, u: F2(x, u) - fm2),
                  dict(N=N, dur=T - 0.23, ineq=[(F2, -np.inf, fm2)])]
    else:
        phases = [dict(N=2 * N, dur=T, ineq=[(F2, -np.inf, fm2)])]
    tm = c["tau_max"]
    return dict(nx=2, nu=1, f=f, L=lambda x, u: c["effort_w"] * u[0] ** 2, x0=[0, 0], xT=[c["psi1"], 0],
                u_continuous=True,
                T_free=c["T_bounds"], time_weight=1.0, phases=phases,
                guess_x=lambda t: [c["psi1"] * min(t / T, 1.0), 2.0], guess_u=lambda t: [5.0 * (1 - 2 * t / T)],
                ubounds=([-tm], [tm]))


def spec(name, N_scale=1):
    if name.startswith("stiff"):
        k = stiff_k(name)
        return stiff_spec(k, N=160 if k < 1000 else 400)
    if name == "chain3":
        return chain_spec(N=20)
    if name in ("slew", "slew_ball"):
        return slew_spec(False, N=40)
    if name in ("slew_bound", "slew_ball_bound"):
        return slew_spec(True)
    if name == "slew_bound_uniform":
        return slew_spec(True, N=80, phased=False)
    if name == "mintime":
        return mint_spec(N=20)
    if name == "mintime_uniform":
        return mint_spec(phased=False)
    raise SystemExit(name)


def solve(name, N_scale=1, d=7, guess=None):
    """guess: a solved Reference whose motion is the initial guess (the finer reference starts from the coarser:
    from the smooth guess the triple pendulum's N = 40 reached another local optimum, J 2.06 for 1.098)."""
    sp = spec(name)
    if guess is not None:
        sc = 1.0
        if "T_free" in sp or len(getattr(guess, "durs", [])) == len(sp["phases"]):   # the guess's own phase durations
            for p, dur in zip(sp["phases"], guess.durs):
                p["dur"] = dur
        sp["guess_x"] = lambda t: guess.evaluate(np.array([t]))[0][:, 0].tolist()
        sp["guess_u"] = lambda t: guess.evaluate(np.array([t]))[2][:, 0].tolist()
    return Reference(sp, N_scale=N_scale, d=d).solve()


# ------------------------------------------------------------------ library names
def lib_quantities(name, t, ref):
    """states, multipliers, inputs (dicts of library names -> arrays) of the reference at times t."""
    x, xd, u = ref.evaluate(t)
    z = 0 * t
    st, lam, inp = {}, {}, {}
    if name.startswith("stiff") or name.startswith("mintime"):
        P = STIFF if name.startswith("stiff") else MINT
        m, L = P["m"], P["L"]
        r = L / 2
        th, w, acc = x[0], x[1], xd[1]
        st.update({"rod.x": r * np.sin(th), "rod.y": -r * np.cos(th), "rod.z": z, "rod.psi": th, "rod.theta": z,
                   "rod.phi": z, "rod.vbar_x": r * np.cos(th) * w, "rod.vbar_y": r * np.sin(th) * w,
                   "rod.vbar_z": z, "rod.omega_x": z, "rod.omega_y": z, "rod.omega_z": w})
        ax = r * (np.cos(th) * acc - np.sin(th) * w**2)
        ay = r * (np.sin(th) * acc + np.cos(th) * w**2)
        lam.update({"hinge.v1.lambda": m * ax, "hinge.v2.lambda": m * ay + m * G, "hinge.v3.lambda": z,
                    "hinge.w1.lambda": z, "hinge.w2.lambda": z})
        inp["motor"] = u[0]
        if name.startswith("stiff"):
            ph, wr = x[2], x[3]
            st.update({"rotor.x": z, "rotor.y": z, "rotor.z": z, "rotor.psi": ph, "rotor.theta": z, "rotor.phi": z,
                       "rotor.vbar_x": z, "rotor.vbar_y": z, "rotor.vbar_z": z, "rotor.omega_x": z,
                       "rotor.omega_y": z, "rotor.omega_z": wr})
            lam.update({"bearing.v1.lambda": z, "bearing.v2.lambda": z + STIFF["m_r"] * G, "bearing.v3.lambda": z,
                        "bearing.w1.lambda": z, "bearing.w2.lambda": z})
        return st, lam, inp
    if name == "chain3":
        _, A, Vel, Com = chain_sym()
        m = CHAIN["m"]
        q, w, wd = x[0:3], x[3:6], xd[3:6]
        n = t.size
        acc = np.zeros((2, 3, n))
        vel = np.zeros((2, 3, n))
        com = np.zeros((2, 3, n))
        for j in range(n):
            acc[:, :, j] = np.array(A(q[:, j], w[:, j], wd[:, j]))
            vel[:, :, j] = np.array(Vel(q[:, j], w[:, j]))
            com[:, :, j] = np.array(Com(q[:, j]))
        F = [None, None, None]
        nxt = np.zeros((2, n))
        for i in (2, 1, 0):   # force on link i at its top joint: m a_i - m g + (force link i+1 gets from link i)
            F[i] = m * acc[:, i, :] + np.array([[0.0], [m * G]]) + nxt
            nxt = F[i]
        for i in range(3):
            b = f"l{i + 1}"
            st.update({f"{b}.x": com[0, i], f"{b}.y": com[1, i], f"{b}.z": z, f"{b}.psi": q[i], f"{b}.theta": z,
                       f"{b}.phi": z, f"{b}.vbar_x": vel[0, i], f"{b}.vbar_y": vel[1, i], f"{b}.vbar_z": z,
                       f"{b}.omega_x": z, f"{b}.omega_y": z, f"{b}.omega_z": w[i]})
            j = f"j{i + 1}"
            lam.update({f"{j}.v1.lambda": F[i][0], f"{j}.v2.lambda": F[i][1], f"{j}.v3.lambda": z,
                        f"{j}.w1.lambda": z, f"{j}.w2.lambda": z})
            inp[f"tau{i + 1}"] = u[i]
        return st, lam, inp
    if name.startswith("slew"):
        q, wb = x[0:4], x[4:7]
        R = np.stack([quat_R(q[:, j]) for j in range(t.size)], axis=-1)   # 3 x 3 x n
        wf = np.einsum("ijn,jn->in", R, wb)
        st.update({"sat.x": z, "sat.y": z, "sat.z": z, "sat.qw": q[0], "sat.qx": q[1], "sat.qy": q[2],
                   "sat.qz": q[3], "sat.vbar_x": z, "sat.vbar_y": z, "sat.vbar_z": z, "sat.omega_x": wf[0],
                   "sat.omega_y": wf[1], "sat.omega_z": wf[2]})
        for i in range(3):
            for j in range(3):
                st[f"R{i + 1}{j + 1}"] = R[i, j]      # derived: from the library's quaternion (normalised)
        for i in range(3):
            inp[f"tau{i + 1}"] = u[i]
        if "ball" in name:
            lam.update({f"pivot.v{k}.lambda": z for k in (1, 2, 3)})
        return st, lam, inp
    raise SystemExit(name)


def horizon(name, ref=None):
    if name.startswith("stiff"):
        return STIFF["T"]
    if name == "chain3":
        return CHAIN["T"]
    if name.startswith("slew"):
        return SLEW["T"]
    return ref.T


def cmd_ref(name):
    t0 = time.process_time()
    if name == "slew_bound":   # phased, from the uniform reference's motion (its own smooth guess: acceptable-level exits)
        u0 = Stored("slew_bound_uniform")
        a = solve(name, 1, guess=u0)
        b = solve(name, 2, guess=a)
    elif name == "chain3":   # N = 20 -> 40 -> 80 -> 160 -> 320 (a) -> 640 (b), each from the coarser (smooth guess at N >= 40: J 2.06, not 1.098)
        a = solve(name, 1)
        for sc in (2, 4, 8, 16):
            a = solve(name, sc, guess=a)
        b = solve(name, 32, guess=a)
    else:
        a = solve(name, 1)
        b = solve(name, 2, guess=a)
    cpu = time.process_time() - t0
    Ta, Tb = horizon(name, a), horizon(name, b)
    s = np.linspace(0, 1, 4001)
    extra = [j / Tb for j in b.junctions]
    s = np.unique(np.concatenate([s] + [[e - 1e-9, e + 1e-9] for e in extra]))
    sa, la, ua = lib_quantities(name, s * Ta, a)
    sb, lb, ub = lib_quantities(name, s * Tb, b)
    out = {"name": name, "ipopt": [a.status, b.status], "J": [a.J, b.J], "T": [Ta, Tb], "junctions": [a.junctions, b.junctions],
           "N_intervals": [len(a.starts), len(b.starts)], "cpu_s": cpu,
           "states_diff": max(float(np.abs(sa[k] - sb[k]).max()) for k in sa),
           "worst_state": max(sa, key=lambda k: float(np.abs(sa[k] - sb[k]).max())),
           "largest_load": max([float(np.abs(v).max()) for v in lb.values()] or [0.0]),
           "inputs_diff": max(float(np.abs(ua[k] - ub[k]).max()) for k in ua)}
    if la:
        out["loads_diff_abs"] = max(float(np.abs(la[k] - lb[k]).max()) for k in la)
        out["loads_diff_rel"] = out["loads_diff_abs"] / out["largest_load"]
    if name.startswith("slew"):
        qn = np.sqrt(sb["sat.qw"] ** 2 + sb["sat.qx"] ** 2 + sb["sat.qy"] ** 2 + sb["sat.qz"] ** 2)
        out["quat_norm_dev"] = float(np.abs(qn - 1).max())
        out["peak_inputs"] = [float(np.abs(ub[k]).max()) for k in ub]
    if name.startswith("mintime"):
        fx, fy = lb["hinge.v1.lambda"], lb["hinge.v2.lambda"]
        out["peak_force"] = float(np.hypot(fx, fy).max())
        out["peak_motor"] = float(np.abs(ub["motor"]).max())
    with open(HERE / f"ref_{name}.pkl", "wb") as fh:
        pickle.dump({"starts": b.starts, "hs": b.hs, "X": b.X, "U": b.U, "d": b.d, "J": b.J, "T": b.T,
                     "durs": b.durs, "status": b.status, "junctions": b.junctions, "uncertainty": out}, fh)
    print("REF " + json.dumps(out))


class Stored:
    """A reference solution read back from ref_NAME.pkl (evaluate() as Reference)."""

    def __init__(self, name):
        from reference import _radau
        with open(HERE / f"ref_{name}.pkl", "rb") as fh:
            D = pickle.load(fh)
        self.__dict__.update(D)
        _, self.basis, _, _, self.ub = _radau(self.d)
        self.dbasis = [b.deriv() for b in self.basis]

    from reference import Reference as _R
    evaluate = _R.evaluate


if __name__ == "__main__":
    cmd_ref(sys.argv[1])
