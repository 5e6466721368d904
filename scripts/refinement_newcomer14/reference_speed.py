"""Independent reference for pendulum_tf_speed (no ocp_constraints import): indirect shooting on Pontryagin's
conditions with the speed arc psi_dot = w_max (a first-order state constraint; with the effort term the torque is
continuous at the arc's entry and exit, Jacobson-Lele-Speyer), DOP853 at rtol (1e-12 default, atol rtol/10).

    1. From t = 0 (theta = omega = 0; H(0) = 0 with tau(0) = tau_max gives l_omega(0) = -I (1 + eps tau_max^2)
       / tau_max), unknown l_theta(0): integrate the state-costate system (tau = sat(-l_omega/(2 eps I)), events at
       the saturation levels) until omega' = 0 (tau = k sin theta: the torque continuous into the arc's, the
       entry tangential); root: omega = w_max there.
    2. On the arc: theta = theta_e + w_max (t - t_e), tau = k sin(theta).
    3. At the exit (unknown theta_x): tau continuous -> l_omega(x+) = -2 eps I k sin(theta_x); H = 0 ->
       l_theta(x+) = -(1 + eps k^2 sin^2 theta_x) / w_max. Integrate until omega = 0; root: theta = pi/2 there.
Two scalar roots (brentq). Accuracy: rtol 1e-12 against 1e-10 (python reference_speed.py).

    evaluate(s, eps=None, rtol=1e-12) -> (states, lambdas, inputs, info) at normalised times s
"""
import sys

import numpy as np
from scipy.integrate import solve_ivp
from scipy.optimize import brentq

from models import params, G


def _consts(P):
    m, L = P["m"], P["L"]
    return m * L**2 / 3, m * G * L / 2


def _integrate(P, y0, t0, stop, rtol, tmax=5.0):
    """integrate from (t0, y0) until the stop event (a function of y, direction) fires; returns pieces
    [(ta, tb, dense, mode)], the final (t, y)."""
    I, k = _consts(P)
    eps, tm = P["eps"], P["tau_max"]
    thr = 2 * eps * I * tm

    def mode_of(lw):
        u = -lw / (2 * eps * I)
        return 1 if u >= tm else (-1 if u <= -tm else 0)

    def rhs(mode):
        def f(t, y):
            th, w, lth, lw = y
            tau = tm if mode == 1 else (-tm if mode == -1 else -lw / (2 * eps * I))
            return [w, (tau - k * np.sin(th)) / I, lw * k * np.cos(th) / I, -lth]
        return f
    t, y = t0, np.array(y0, float)
    mode = mode_of(y[3])
    pieces = []
    for _ in range(20):
        # level crossings with directions (so an event is not found again at the start of the next piece)
        lev_p = lambda t, y: y[3] + thr     # u = +tm level
        lev_m = lambda t, y: y[3] - thr     # u = -tm level
        es = lambda t, y: stop[0](y)
        es.direction = stop[1]
        if mode == 1:
            lev_p.direction = 1             # leaving +saturation: l_omega rises through -thr
            evs = [es, lev_p]
        elif mode == -1:
            lev_m.direction = -1
            evs = [es, lev_m]
        else:
            lev_p.direction = -1            # entering +saturation
            lev_m.direction = 1             # entering -saturation
            evs = [es, lev_p, lev_m]
        for e in evs:
            e.terminal = True
        r = solve_ivp(rhs(mode), (t, t0 + tmax), y, method="DOP853", rtol=rtol, atol=rtol / 10, events=evs,
                      dense_output=True)
        pieces.append((t, r.t[-1], r.sol, mode))
        t, y = r.t[-1], r.y[:, -1]
        if r.status != 1:
            raise RuntimeError("no stop event")
        if len(r.t_events[0]) and abs(r.t_events[0][0] - t) < 1e-15:
            return pieces, t, y
        # a saturation level crossed: switch mode
        mode = 0 if mode != 0 else (1 if len(r.t_events[1]) else -1)
        if t - pieces[-1][0] < 1e-14 and len(pieces) > 1:
            pass
    raise RuntimeError("too many pieces")


def solve(eps=None, rtol=1e-12):
    P = params("pendulum_tf_speed", eps)
    I, k = _consts(P)
    eps_, tm, wm = P["eps"], P["tau_max"], P["w_max"]
    lw0 = -I * (1 + eps_ * tm**2) / tm
    def tau_of(y):
        return float(np.clip(-y[3] / (2 * eps_ * I), -tm, tm))

    # the entry is tangential (omega' = 0 there, tau continuous): stop at the first maximum of omega
    # (tau - k sin theta = 0, falling) and ask omega = w_max there
    stop_w = (lambda y: tau_of(y) - k * np.sin(y[0]), -1)

    def res_entry(lth0):
        _, te, ye = _integrate(P, [0.0, 0.0, lth0, lw0], 0.0, stop_w, rtol)
        return ye[1] - wm
    grid = np.linspace(-0.3, 0.0, 61)
    vals = []
    for g in grid:
        try:
            vals.append(res_entry(g))
        except RuntimeError:
            vals.append(np.nan)
    vals = np.array(vals)
    idx = [i for i in range(len(grid) - 1) if np.isfinite(vals[i]) and np.isfinite(vals[i + 1])
           and vals[i] * vals[i + 1] < 0]
    lth0 = brentq(res_entry, grid[idx[0]], grid[idx[0] + 1], xtol=1e-15, rtol=1e-15)
    pA, te, ye = _integrate(P, [0.0, 0.0, lth0, lw0], 0.0, stop_w, rtol)
    th_e = ye[0]
    stop_0 = (lambda y: y[1], -1)

    def after_exit(thx):
        lw = -2 * eps_ * I * k * np.sin(thx)
        lth = -(1 + eps_ * k**2 * np.sin(thx)**2) / wm
        return _integrate(P, [thx, wm, lth, lw], 0.0, stop_0, rtol)

    def res_exit(thx):
        _, _, yf = after_exit(thx)
        return yf[0] - np.pi / 2
    gx = np.linspace(th_e, np.pi / 2, 60)
    vx = np.array([res_exit(g) for g in gx])
    j = [i for i in range(len(gx) - 1) if vx[i] * vx[i + 1] < 0][0]
    thx = brentq(res_exit, gx[j], gx[j + 1], xtol=1e-15, rtol=1e-15)
    pD, tD, yf = after_exit(thx)
    tx = te + (thx - th_e) / wm
    T = tx + tD
    # junctions: A pieces' ends, entry, exit, D pieces' ends (shifted)
    junc = [p[1] for p in pA[:-1]] + [te, tx] + [tx + p[1] for p in pD[:-1]]
    return dict(P=P, pA=pA, pD=pD, te=te, tx=tx, th_e=th_e, thx=thx, T=T, lth0=lth0, junctions=junc,
                final=yf, res_entry=res_entry(lth0), res_exit=res_exit(thx))


_CACHE = {}


def evaluate(s, eps=None, rtol=1e-12):
    key = (eps, rtol)
    if key not in _CACHE:
        _CACHE[key] = solve(eps, rtol)
    R = _CACHE[key]
    P = R["P"]
    I, k = _consts(P)
    eps_, tm, wm = P["eps"], P["tau_max"], P["w_max"]
    T = R["T"]
    t = np.clip(np.asarray(s, float) * T, 0, T)
    th, w, tau = np.zeros_like(t), np.zeros_like(t), np.zeros_like(t)
    done = np.zeros_like(t, bool)

    def fill(pieces, off):
        for ta, tb, dense, mode in pieces:
            sel = (~done) & (t >= ta + off) & (t <= tb + off)
            if sel.any():
                Y = dense(t[sel] - off)
                th[sel], w[sel] = Y[0], Y[1]
                tau[sel] = tm if mode == 1 else (-tm if mode == -1 else np.clip(-Y[3] / (2 * eps_ * I), -tm, tm))
                done[sel] = True
    fill(R["pA"], 0.0)
    arc = (~done) & (t <= R["tx"])
    th[arc] = R["th_e"] + wm * (t[arc] - R["te"])
    w[arc] = wm
    tau[arc] = k * np.sin(th[arc])
    done |= arc
    fill(R["pD"], R["tx"])
    assert done.all()
    al = (tau - k * np.sin(th)) / I
    m, L = P["m"], P["L"]
    c, sn = np.cos(th), np.sin(th)
    n = len(t)
    Z = np.zeros
    st = {f"rod.{q}": Z(n) for q in ("x", "y", "z", "psi", "theta", "phi", "psi_dot", "theta_dot", "phi_dot",
                                     "vbar_x", "vbar_y", "vbar_z", "omega_x", "omega_y", "omega_z")}
    st["rod.x"], st["rod.y"] = L / 2 * sn, -L / 2 * c
    st["rod.psi"], st["rod.psi_dot"], st["rod.omega_z"] = th, w, w
    st["rod.vbar_x"], st["rod.vbar_y"] = L / 2 * w * c, L / 2 * w * sn
    ax = L / 2 * (al * c - w**2 * sn)
    ay = L / 2 * (al * sn + w**2 * c)
    lam = {"hinge.v1.lambda": m * ax, "hinge.v2.lambda": m * (ay + G), "hinge.v3.lambda": Z(n),
           "hinge.w1.lambda": Z(n), "hinge.w2.lambda": Z(n)}
    from scipy.integrate import simpson
    if "J" not in R:
        ss = np.linspace(0, 1, 40001)
        R["J"] = None
        tt = evaluate(ss, eps, rtol)[2]["tau"]
        R["J"] = T + eps_ * simpson(tt**2, x=ss * T)
        R["ls"] = None
    info = dict(T=T, junctions=list(R["junctions"]), objective=R["J"],
                load_scale=max(np.abs(lam["hinge.v1.lambda"]).max(), np.abs(lam["hinge.v2.lambda"]).max()))
    return st, lam, {"tau": tau}, info


def load_scale(eps=None, rtol=1e-12):
    _, lam, _, _ = evaluate(np.linspace(0, 1, 20001), eps, rtol)
    return max(np.abs(lam["hinge.v1.lambda"]).max(), np.abs(lam["hinge.v2.lambda"]).max())


if __name__ == "__main__":
    eps = float(sys.argv[1]) if len(sys.argv) > 1 else None
    s = np.linspace(0, 1, 4001)
    out = {}
    for rtol in (1e-12, 1e-10):
        R = solve(eps, rtol)
        _CACHE[(eps, rtol)] = R
        out[rtol] = evaluate(s, eps, rtol)
        print(f"rtol {rtol:g}: T={R['T']:.15f} l_theta0={R['lth0']:.15f} entry t={R['te']:.12f} theta={R['th_e']:.12f}"
              f" exit t={R['tx']:.12f} theta={R['thx']:.12f} junctions={[round(j, 12) for j in R['junctions']]}"
              f" residuals entry {R['res_entry']:.1e} exit {R['res_exit']:.1e}; final omega {R['final'][1]:.1e}")
    a, b = out[1e-12], out[1e-10]
    ls = load_scale(eps)
    print(f"rtol 1e-12 vs 1e-10: T {abs(a[3]['T'] - b[3]['T']):.2e}, states "
          f"{max(np.abs(a[0][q] - b[0][q]).max() for q in a[0]):.2e}, loads/scale "
          f"{max(np.abs(a[1][q] - b[1][q]).max() for q in a[1]) / ls:.2e}, tau {np.abs(a[2]['tau'] - b[2]['tau']).max():.2e}")
    print(f"objective {a[3]['objective']:.12f}; load scale {ls:.6f}; max psi_dot {a[0]['rod.psi_dot'].max():.15f}; "
          f"max |tau| {np.abs(a[2]['tau']).max():.12f}; tau(T) {a[2]['tau'][-1]:.6f}")
