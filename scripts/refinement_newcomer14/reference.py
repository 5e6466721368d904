"""Independent references (no ocp_constraints import), evaluated at NORMALISED times s in [0, 1].

    evaluate(name, s, eps=None, rtol=1e-12) -> (states, lambdas, inputs, info)
        states : {sample name: array} every body coordinate, rate and speed (absolute SI), at t = s * T_ref
        lambdas: {"<joint>.<c>.lambda": array} (library conventions, as in scripts/refinement_newcomer12)
        inputs : {input: array}
        info   : dict(T=T_ref, junctions=[t ...] (s), objective=J_ref, load_scale=largest load, ...)

block_tf      : Pontryagin closed form. H = 1 + eps F^2 + p_x v + p_v F/m = 0 (free T, autonomous);
                F antisymmetric about tau = T/2 where F = 0, p_v = 0 -> p_x = -1/v_mid, p_v = (t - tau)/v_mid,
                F = sat((tau - t)/(2 eps m v_mid)): bang on [0, t1], linear on [t1, T - t1], bang after.
                delta = tau - t1 = 2 eps m v_mid F_max, v_mid = a (t1 + delta/2), x(tau) = D/2 -> brentq in v_mid.
block_tf_speed: closed form: p_x = -1/v_max (H = 0 on the coast, F = 0), F = sat((t2 - t)/(2 eps m v_max)),
                reaching 0 continuously at the arc's entry t2; delta = 2 eps m v_max F_max, t1 = v_max/a - delta/2,
                t2 = t1 + delta, coast to T - t2, T = 2 t2 + (D - 2 x(t2))/v_max.
pendulum_tf_speed: reference_speed.py (indirect shooting with the speed arc).
pendulum_tf   : indirect single shooting on Pontryagin's conditions (theta, omega, l_theta, l_omega),
                tau = sat(-l_omega/(2 eps I)); unknowns l_theta(0), l_omega(0), T; residuals theta(T) - pi/2,
                omega(T), H(0); DOP853 at rtol (default 1e-12, atol rtol/10), integrated piecewise between the
                saturation junctions (events), fsolve; loads by Newton-Euler (hinge force = m a_com - m g).
"""
import sys

import numpy as np
from scipy.integrate import solve_ivp
from scipy.optimize import brentq, fsolve

from models import params, G

Z = np.zeros


def _zero_body(st, name, n):
    for k in ("x", "y", "z", "psi", "theta", "phi", "psi_dot", "theta_dot", "phi_dot",
              "vbar_x", "vbar_y", "vbar_z", "omega_x", "omega_y", "omega_z"):
        st[f"{name}.{k}"] = Z(n)


def _ramp(t, a, t1, delta):
    """x, v on [0, t1 + delta]: acceleration a up to t1, then a (1 - (t - t1)/delta)."""
    t = np.asarray(t, float)
    u = np.clip(t - t1, 0.0, None)
    tb = np.minimum(t, t1)
    v = a * tb + a * (u - u**2 / (2 * delta))
    x = a * tb**2 / 2 + a * t1 * u + a * (u**2 / 2 - u**3 / (6 * delta))
    return x, v


def block_closed(name, eps=None):
    P = params(name, eps)
    m, D, Fm, eps = P["m"], P["D"], P["F_max"], P["eps"]
    a = Fm / m
    if name == "block_tf":
        def res(vmid):
            delta = 2 * eps * m * vmid * Fm
            t1 = vmid / a - delta / 2
            return float(_ramp(t1 + delta, a, t1, delta)[0]) - D / 2
        vmid = brentq(res, 1e-6, 100.0, xtol=1e-16, rtol=1e-15)
        delta = 2 * eps * m * vmid * Fm
        t1 = vmid / a - delta / 2
        assert t1 > 0
        tau = t1 + delta
        T = 2 * tau
        t2, coast, vtop = tau, 0.0, vmid
    else:
        vmax = P["v_max"]
        delta = 2 * eps * m * vmax * Fm
        t1 = vmax / a - delta / 2
        t2 = t1 + delta
        x2 = float(_ramp(t2, a, t1, delta)[0])
        coast = (D - 2 * x2) / vmax
        assert t1 > 0 and coast > 0
        T = 2 * t2 + coast
        vtop = vmax
    J = T + 2 * eps * Fm**2 * (t1 + delta / 3)
    info = dict(T=T, t1=t1, t2=t2, delta=delta, vtop=vtop, objective=J, junctions=[t1, t2, T - t2, T - t1],
                load_scale=max(m * G, P["h"] * Fm), H0=1 + eps * Fm**2 - t2 * Fm / (m * vtop))
    return P, info


def block_eval(name, s, eps=None):
    P, info = block_closed(name, eps)
    T, t1, t2, delta = info["T"], info["t1"], info["t2"], info["delta"]
    a = P["F_max"] / P["m"]
    t = np.asarray(s, float) * T
    th = np.minimum(t, T - t)
    x, v = _ramp(np.minimum(th, t2), a, t1, delta)
    xt2, vt2 = _ramp(t2, a, t1, delta)
    x = np.where(th > t2, xt2 + vt2 * (th - t2), x)
    v = np.where(th > t2, vt2, v)
    x = np.where(t <= T / 2, x, P["D"] - x)
    F = np.clip((t2 - t) / (2 * P["eps"] * P["m"] * info["vtop"]), -P["F_max"], P["F_max"])
    F = np.where(t <= T / 2, np.clip(F, 0, None), -np.clip((t2 - (T - t)) / (2 * P["eps"] * P["m"] * info["vtop"]),
                                                             0, P["F_max"]))
    n = len(t)
    st = {}
    _zero_body(st, "block", n)
    st["block.x"], st["block.vbar_x"] = x, v
    lam = {"rail.n1.lambda": np.full(n, P["m"] * G), "rail.n2.lambda": Z(n), "rail.w1.lambda": Z(n),
           "rail.w2.lambda": Z(n), "rail.w3.lambda": P["h"] * F}
    return st, lam, {"F": F}, info


def block_check(name, eps=None):
    """integrate the closed form's F (DOP853, rtol 1e-13, breaks at the junctions): final state, and the
    closed-form states on a grid against the integration."""
    P, info = block_closed(name, eps)
    T = info["T"]
    Ff = lambda t: block_eval(name, np.array([t / T]), eps)[2]["F"][0]
    br = np.unique(np.r_[0.0, info["junctions"], T])
    y = np.array([0.0, 0.0])
    err = 0.0
    for a_, b_ in zip(br[:-1], br[1:]):
        tt = np.linspace(a_, b_, 50)
        r = solve_ivp(lambda t, y: [y[1], Ff(t) / P["m"]], (a_, b_), y, method="DOP853", rtol=1e-13, atol=1e-15,
                      t_eval=tt)
        st = block_eval(name, tt / T, eps)[0]
        err = max(err, np.abs(r.y[0] - st["block.x"]).max(), np.abs(r.y[1] - st["block.vbar_x"]).max())
        y = r.y[:, -1]
    print(f"{name} eps={P['eps']:g}: T={T:.15f} J={info['objective']:.15f} t1={info['t1']:.15f} t2={info['t2']:.15f} "
          f"H(0)={info['H0']:.2e}; integrated final state x-D={y[0]-P['D']:.2e} v={y[1]:.2e}; closed form vs "
          f"integration on 50/piece: {err:.2e}")


def block_t0_eval(s, eps=None):
    """block_tf_speed_t0: coast at v_max on [0, tc] (F = 0, the arc from t0), then the mirror image of
    block_tf_speed's acceleration: v(T - r) = v_acc(r), x(T - r) = D - x_acc(r), r in [0, t2]. T = tc + t2,
    tc = (D - x_acc(t2)) / v_max. Same H = 0 argument (p_x = -1/v_max on the arc)."""
    P = params("block_tf_speed_t0", eps)
    m, D, Fm, eps_, vmax = P["m"], P["D"], P["F_max"], P["eps"], P["v_max"]
    a = Fm / m
    delta = 2 * eps_ * m * vmax * Fm
    t1 = vmax / a - delta / 2
    t2 = t1 + delta
    x2 = float(_ramp(t2, a, t1, delta)[0])
    tc = (D - x2) / vmax
    assert tc > 0 and t1 > 0
    T = tc + t2
    t = np.asarray(s, float) * T
    r = np.clip(T - t, 0, t2)
    xa, va = _ramp(r, a, t1, delta)
    x = np.where(t <= tc, vmax * t, D - xa)
    v = np.where(t <= tc, vmax, va)
    F = -np.clip((t - tc) / (2 * eps_ * m * vmax), 0, Fm)
    n = len(t)
    st = {}
    _zero_body(st, "block", n)
    st["block.x"], st["block.vbar_x"] = x, v
    lam = {"rail.n1.lambda": np.full(n, m * G), "rail.n2.lambda": Z(n), "rail.w1.lambda": Z(n),
           "rail.w2.lambda": Z(n), "rail.w3.lambda": P["h"] * F}
    J = T + eps_ * Fm**2 * (t1 + delta / 3)
    return st, lam, {"F": F}, dict(T=T, junctions=[tc, tc + delta], objective=J, load_scale=max(m * G, P["h"] * Fm),
                                   t1=t1, t2=t2, delta=delta)


def block_tend_eval(s, eps=None):
    """block_tf_speed_tend: the time reversal of block_tf_speed_t0 (same T): block_tf_speed's acceleration on
    [0, t2], then the coast at v_max to x = D (the arc ends at T). F(t) = -F_t0(T - t)."""
    st0, lam0, inp0, info = block_t0_eval(1.0 - np.asarray(s, float), eps)
    P = params("block_tf_speed_tend", eps)
    st = dict(st0)
    st["block.x"] = P["D"] - st0["block.x"]
    st["block.vbar_x"] = st0["block.vbar_x"]
    F = -inp0["F"]
    lam = dict(lam0)
    lam["rail.w3.lambda"] = P["h"] * F
    T = info["T"]
    info = dict(info, junctions=[T - j for j in info["junctions"]][::-1])
    return st, lam, {"F": F}, info


def block_tend_check(eps=None):
    P = params("block_tf_speed_tend", eps)
    _, _, _, info = block_tend_eval(np.array([0.0]), eps)
    T = info["T"]
    Ff = lambda t: block_tend_eval(np.array([t / T]), eps)[2]["F"][0]
    br = np.unique(np.r_[0.0, info["junctions"], T])
    y = np.array([0.0, 0.0])
    err = 0.0
    for a_, b_ in zip(br[:-1], br[1:]):
        tt = np.linspace(a_, b_, 50)
        r = solve_ivp(lambda t, y: [y[1], Ff(t) / P["m"]], (a_, b_), y, method="DOP853", rtol=1e-13, atol=1e-15,
                      t_eval=tt)
        st = block_tend_eval(tt / T, eps)[0]
        err = max(err, np.abs(r.y[0] - st["block.x"]).max(), np.abs(r.y[1] - st["block.vbar_x"]).max())
        y = r.y[:, -1]
    print(f"block_tf_speed_tend eps={P['eps']:g}: T={T:.15f} junctions={info['junctions']}; integrated final state "
          f"x-D={y[0]-P['D']:.2e} v-v_max={y[1]-P['v_max']:.2e}; closed form vs integration: {err:.2e}")


def block_t0_check(eps=None):
    P = params("block_tf_speed_t0", eps)
    _, _, _, info = block_t0_eval(np.array([0.0]), eps)
    T = info["T"]
    Ff = lambda t: block_t0_eval(np.array([t / T]), eps)[2]["F"][0]
    br = np.unique(np.r_[0.0, info["junctions"], T])
    y = np.array([0.0, P["v_max"]])
    err = 0.0
    for a_, b_ in zip(br[:-1], br[1:]):
        tt = np.linspace(a_, b_, 50)
        r = solve_ivp(lambda t, y: [y[1], Ff(t) / P["m"]], (a_, b_), y, method="DOP853", rtol=1e-13, atol=1e-15,
                      t_eval=tt)
        st = block_t0_eval(tt / T, eps)[0]
        err = max(err, np.abs(r.y[0] - st["block.x"]).max(), np.abs(r.y[1] - st["block.vbar_x"]).max())
        y = r.y[:, -1]
    print(f"block_tf_speed_t0 eps={P['eps']:g}: T={T:.15f} J={info['objective']:.15f} junctions={info['junctions']}; "
          f"integrated final state x-D={y[0]-P['D']:.2e} v={y[1]:.2e}; closed form vs integration: {err:.2e}")


# ---------------------------------------------------------------- pendulum: indirect shooting
def _pend(P):
    m, L = P["m"], P["L"]
    return m * L**2 / 3, m * G * L / 2


def _pend_rhs(P, sat):
    I, k = _pend(P)
    eps, tm = P["eps"], P["tau_max"]

    def tau_of(lw):
        if sat == 1:
            return tm
        if sat == -1:
            return -tm
        return -lw / (2 * eps * I)

    def f(t, y):
        th, w, lth, lw = y
        tau = tau_of(lw)
        return [w, (tau - k * np.sin(th)) / I, lw * k * np.cos(th) / I, -lth]
    return f, tau_of


def _mode(P, lw):
    I, _ = _pend(P)
    u = -lw / (2 * P["eps"] * I)
    return 1 if u >= P["tau_max"] else (-1 if u <= -P["tau_max"] else 0)


def pend_shoot(P, z, rtol=1e-12, t_eval=None):
    """integrate from (0, 0, l_theta0, l_omega0) over [0, T] piecewise; returns final state, junction times, and
    (if t_eval) the states at t_eval."""
    lth0, lw0, T = z
    I, k = _pend(P)
    y = np.array([0.0, 0.0, lth0, lw0])
    t = 0.0
    junc = []
    out = {}
    te = None if t_eval is None else np.asarray(t_eval, float)
    mode = _mode(P, lw0)
    thr = -2 * P["eps"] * I * P["tau_max"]      # l_omega at tau_unsat = +tau_max ; -thr at -tau_max
    for _ in range(20):
        f, _ = _pend_rhs(P, mode)
        ev1 = lambda t, y: y[3] - thr
        ev2 = lambda t, y: y[3] + thr
        ev1.terminal = ev2.terminal = True
        evs = [ev1, ev2]
        # ignore an event at the very start of a piece
        if abs(y[3] - thr) < 1e-14 or abs(y[3] + thr) < 1e-14:
            pass
        sel = None if te is None else te[(te >= t) & (te <= T)]
        r = solve_ivp(f, (t, T), y, method="DOP853", rtol=rtol, atol=rtol / 10, events=evs if t > -1 else None,
                      dense_output=True)
        tend = r.t[-1]
        if sel is not None:
            sel = sel[sel <= tend]
            if len(sel):
                Y = r.sol(sel)
                for j, tj in enumerate(sel):
                    out[tj] = (Y[:, j], mode)
        y = r.y[:, -1]
        if r.status == 1 and tend < T - 1e-15:
            if tend - t < 1e-13:          # an event at the start: step past it
                pass
            junc.append(tend)
            t = tend
            # new mode from the crossing direction
            d = f(t, y)[3]
            newmode = mode
            if abs(y[3] - thr) < abs(y[3] + thr):   # crossing +tau_max level
                newmode = 0 if mode == 1 else 1
            else:
                newmode = 0 if mode == -1 else -1
            mode = newmode
            # nudge: integrate the new mode an instant so the event is not found again at t
            f2, _ = _pend_rhs(P, mode)
            r2 = solve_ivp(f2, (t, min(t + 1e-9, T)), y, method="DOP853", rtol=rtol, atol=rtol / 10, dense_output=True)
            if sel is not None:
                s2 = te[(te >= t) & (te <= r2.t[-1])]
                if len(s2):
                    Y = r2.sol(s2)
                    for j, tj in enumerate(s2):
                        out[tj] = (Y[:, j], mode)
            y, t = r2.y[:, -1], r2.t[-1]
            continue
        break
    return y, junc, out


def pend_solve(P, rtol=1e-12, z0=None):
    I, k = _pend(P)
    eps, tm = P["eps"], P["tau_max"]

    def H0(z):
        lth0, lw0, T = z
        _, tau_of = _pend_rhs(P, _mode(P, lw0))
        tau = tau_of(lw0)
        return 1 + eps * tau**2 + lw0 * tau / I          # theta = omega = 0 at t = 0

    def res(z):
        y, _, _ = pend_shoot(P, z, rtol)
        return [y[0] - np.pi / 2, y[1], H0(z)]
    if z0 is None:
        lw0 = -I * (1 + eps * tm**2) / tm               # H(0) = 0 with tau(0) = tau_max
        z0 = [-0.25, lw0, 0.55]
    z, info, ier, msg = fsolve(res, z0, xtol=1e-14, full_output=True)
    for _ in range(3):                                # polish
        z, info, ier, msg = fsolve(res, z, xtol=1e-15, full_output=True)
    r = res(z)
    return z, r, ier, msg


_CACHE = {}


def pend_eval(s, eps=None, rtol=1e-12):
    P = params("pendulum_tf", eps)
    key = (P["eps"], rtol)
    if key not in _CACHE:
        z, r, ier, msg = pend_solve(P, rtol)
        _CACHE[key] = (z, r)
    z, r = _CACHE[key]
    T = z[2]
    I, k = _pend(P)
    s = np.asarray(s, float)
    tt = np.clip(s * T, 0, T)
    uniq = np.unique(tt)
    _, junc, out = pend_shoot(P, z, rtol, t_eval=uniq)
    Y = np.array([out[t][0] for t in uniq]).T
    modes = np.array([out[t][1] for t in uniq])
    idx = np.searchsorted(uniq, tt)
    th, w, lth, lw = Y[:, idx]
    md = modes[idx]
    tau = np.where(md == 1, P["tau_max"], np.where(md == -1, -P["tau_max"], -lw / (2 * P["eps"] * I)))
    al = (tau - k * np.sin(th)) / I
    L, m = P["L"], P["m"]
    c, sn = np.cos(th), np.sin(th)
    n = len(tt)
    st = {}
    _zero_body(st, "rod", n)
    st["rod.x"], st["rod.y"] = L / 2 * sn, -L / 2 * c
    st["rod.psi"], st["rod.psi_dot"], st["rod.omega_z"] = th, w, w
    st["rod.vbar_x"], st["rod.vbar_y"] = L / 2 * w * c, L / 2 * w * sn
    ax = L / 2 * (al * c - w**2 * sn)
    ay = L / 2 * (al * sn + w**2 * c)
    lam = {"hinge.v1.lambda": m * ax, "hinge.v2.lambda": m * (ay + G), "hinge.v3.lambda": Z(n),
           "hinge.w1.lambda": Z(n), "hinge.w2.lambda": Z(n)}
    # objective: T + eps int tau^2 (trapezoid on a fine grid is not enough: integrate tau^2 piecewise by quadrature)
    info = dict(T=T, junctions=list(junc), z=list(z), residual=list(map(float, r)), objective=None,
                load_scale=None)
    return st, lam, {"tau": tau}, info


def pend_objective_and_scale(eps=None, rtol=1e-12):
    P = params("pendulum_tf", eps)
    s = np.linspace(0, 1, 20001)
    st, lam, inp, info = pend_eval(s, eps, rtol)
    T = info["T"]
    from scipy.integrate import simpson
    J = T + P["eps"] * simpson(inp["tau"]**2, x=s * T)
    ls = np.hypot(lam["hinge.v1.lambda"], lam["hinge.v2.lambda"]).max()
    ls = max(np.abs(lam["hinge.v1.lambda"]).max(), np.abs(lam["hinge.v2.lambda"]).max())
    return J, ls


def evaluate(name, s, eps=None, rtol=1e-12):
    if name in ("block_tf", "block_tf_speed"):
        return block_eval(name, s, eps)
    if name == "block_tf_speed_t0":
        return block_t0_eval(s, eps)
    if name == "block_tf_speed_tend":
        return block_tend_eval(s, eps)
    if name == "pendulum_tf_speed_path":
        name = "pendulum_tf_speed"
    if name == "pendulum_tf_speed":
        import reference_speed
        st, lam, inp, info = reference_speed.evaluate(s, eps, rtol)
        info["load_scale"] = reference_speed.load_scale(eps, rtol)
        return st, lam, inp, info
    st, lam, inp, info = pend_eval(s, eps, rtol)
    J, ls = pend_objective_and_scale(eps, rtol)
    info["objective"], info["load_scale"] = J, ls
    return st, lam, inp, info


if __name__ == "__main__":
    name = sys.argv[1]
    eps = float(sys.argv[2]) if len(sys.argv) > 2 else None
    if name == "block_tf_speed_t0":
        block_t0_check(eps)
    elif name == "block_tf_speed_tend":
        block_tend_check(eps)
    elif name.startswith("block"):
        block_check(name, eps)
    else:
        P = params("pendulum_tf", eps)
        s = np.linspace(0, 1, 2001)
        res = {}
        for rtol in (1e-12, 1e-10):
            st, lam, inp, info = pend_eval(s, eps, rtol)
            res[rtol] = (st, lam, inp, info)
            print(f"rtol {rtol:g}: T={info['T']:.15f} z={info['z']} residual={info['residual']} "
                  f"junctions={info['junctions']}")
        a, b = res[1e-12], res[1e-10]
        ds = max(np.abs(a[0][k] - b[0][k]).max() for k in a[0])
        dl = max(np.abs(a[1][k] - b[1][k]).max() for k in a[1])
        du = np.abs(a[2]["tau"] - b[2]["tau"]).max()
        print(f"rtol 1e-12 vs 1e-10: T {abs(a[3]['T'] - b[3]['T']):.2e}, states {ds:.2e}, loads {dl:.2e} N, "
              f"tau {du:.2e} N m (on 2001 normalised times)")
        J, ls = pend_objective_and_scale(eps)
        print(f"objective {J:.12f}, load scale {ls:.6f} N; tau(0)={a[2]['tau'][0]:.6f}, tau(T)={a[2]['tau'][-1]:.6f}, "
              f"min tau {a[2]['tau'].min():.6f}")
