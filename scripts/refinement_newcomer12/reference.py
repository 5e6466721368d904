"""Independent references (no ocp_constraints import).

    evaluate(name, tt, **kw) -> (states, lambdas, inputs, info)
        states : {sample name: array} every body coordinate, rate and speed (absolute SI)
        lambdas: {"<joint>.<c>.lambda": array} in the library's conventions (read off model.describe(), see README)
        inputs : {input: array}
        info   : dict(junctions=[...], objective=..., notes)

fuel : closed form (bang-off-bang, double integrator), rail loads by Newton-Euler.
mayer: closed form (bang-bang, switch at T/2), hinge loads by Newton-Euler.
shaft: minimal coordinate r(t) on the table turning at phi' = Omega(t): m (r'' - r Omega^2) = u - k (r - r0);
       min int u^2: Pontryagin's linear BVP (r, v, l1, l2), u = -l2 / (2 m), solved by superposition with DOP853
       (rtol 1e-13, atol 1e-14); its accuracy: against rtol 1e-11 (python reference.py shaft).
"""
import sys

import numpy as np
from scipy.integrate import solve_ivp

from models import PARAMS, G, Omega_np

Z = np.zeros


def _zero_body(st, name, n):
    for k in ("x", "y", "z", "psi", "theta", "phi", "psi_dot", "theta_dot", "phi_dot",
              "vbar_x", "vbar_y", "vbar_z", "omega_x", "omega_y", "omega_z"):
        st[f"{name}.{k}"] = Z(n)


def _fuel_reg(tt, eps):
    """fuel with eps (up^2 + um^2) added: p(t) = beta (T/2 - t), up = clip((p - 1) / (2 eps), 0, u_max); beta by
    brentq on x(T/2) = D/2 (the acceleration is odd about T/2); states in closed form per piece."""
    from scipy.optimize import brentq
    from scipy.integrate import quad
    P = PARAMS["fuel"]
    m, T, D, umax, h = P["m"], P["T"], P["D"], P["u_max"], P["h"]
    A, c = umax / m, 1 / (2 * eps * m)

    def pieces(beta):
        ta = max(T / 2 - (1 + 2 * eps * umax) / beta, 0.0)
        tb = T / 2 - 1 / beta
        return ta, tb

    def xv(t, beta):                     # t in [0, T/2]
        ta, tb = pieces(beta)
        k0 = c * (beta * T / 2 - 1)
        va, xa = A * ta, A * ta**2 / 2

        def ramp(t):
            v = va + k0 * (t - ta) - c * beta * (t**2 - ta**2) / 2
            x = xa + va * (t - ta) + k0 * (t - ta)**2 / 2 - c * beta * ((t**3 - ta**3) / 6 - ta**2 * (t - ta) / 2)
            return x, v
        xb, vb = ramp(tb)
        t = np.asarray(t, float)
        x = np.where(t < ta, A * t**2 / 2, np.where(t < tb, ramp(t)[0], xb + vb * (t - tb)))
        v = np.where(t < ta, A * t, np.where(t < tb, ramp(t)[1], vb))
        return x, v
    beta = brentq(lambda b: float(xv(T / 2, b)[0]) - D / 2, 1 / (T / 2) * 1.0000001, 1e4, xtol=1e-15, rtol=1e-15)
    th = np.minimum(tt, T - tt)
    x, v = xv(th, beta)
    x = np.where(tt <= T / 2, x, D - x)
    p = beta * (T / 2 - tt)
    up = np.clip((p - 1) / (2 * eps), 0, umax)
    umi = np.clip((-p - 1) / (2 * eps), 0, umax)
    ta, tb = pieces(beta)
    f = lambda t: (lambda q: q + eps * q**2)(np.clip((beta * (T / 2 - t) - 1) / (2 * eps), 0, umax))
    J = 2 * sum(quad(f, a, b, epsabs=1e-15, epsrel=1e-14)[0] for a, b in ((0, ta), (ta, tb)) if b > a)
    return x, v, up, umi, [ta, tb, T - tb, T - ta], J, beta


def fuel(tt, reg=0.0, **kw):
    P = PARAMS["fuel"]
    m, T, D, um, h = P["m"], P["T"], P["D"], P["u_max"], P["h"]
    if reg:
        x, v, up, umi, junc, J, beta = _fuel_reg(tt, reg)
        n = len(tt)
        st = {}
        _zero_body(st, "slider", n)
        st["slider.x"], st["slider.vbar_x"] = x, v
        lam = {"rail.n1.lambda": np.full(n, m * G), "rail.n2.lambda": Z(n), "rail.w1.lambda": Z(n),
               "rail.w2.lambda": Z(n), "rail.w3.lambda": h * (up - umi)}
        return st, lam, {"up": up, "um": umi}, dict(junctions=junc, objective=J, load_scale=m * G, beta=beta)
    a = um / m
    t1 = T / 2 - np.sqrt(T**2 / 4 - D / a)
    t2 = T - t1
    v1 = a * t1
    x = np.where(tt < t1, a * tt**2 / 2, np.where(tt < t2, a * t1**2 / 2 + v1 * (tt - t1), D - a * (T - tt)**2 / 2))
    v = np.where(tt < t1, a * tt, np.where(tt < t2, v1, a * (T - tt)))
    up = np.where(tt < t1, um, 0.0)
    umi = np.where(tt > t2, um, 0.0)
    n = len(tt)
    st = {}
    _zero_body(st, "slider", n)
    st["slider.x"], st["slider.vbar_x"] = x, v
    lam = {"rail.n1.lambda": np.full(n, m * G), "rail.n2.lambda": Z(n), "rail.w1.lambda": Z(n),
           "rail.w2.lambda": Z(n), "rail.w3.lambda": h * (up - umi)}
    return st, lam, {"up": up, "um": umi}, dict(junctions=[t1, t2], objective=2 * um * t1, load_scale=m * G)


def mayer(tt, **kw):
    P = PARAMS["mayer"]
    m, L, T, tm = P["m"], P["L"], P["T"], P["tau_max"]
    IA = m * L**2 / 3
    al = tm / IA
    ts = T / 2
    psi = np.where(tt < ts, al * tt**2 / 2, al * ts**2 / 2 + al * ts * (tt - ts) - al * (tt - ts)**2 / 2)
    w = np.where(tt < ts, al * tt, al * (T - tt))
    wd = np.where(tt < ts, al, -al)
    n = len(tt)
    st = {}
    _zero_body(st, "rod", n)
    c, s = np.cos(psi), np.sin(psi)
    st["rod.x"], st["rod.y"] = L / 2 * s, -L / 2 * c
    st["rod.psi"], st["rod.psi_dot"], st["rod.omega_z"] = psi, w, w
    st["rod.vbar_x"], st["rod.vbar_y"] = L / 2 * w * c, L / 2 * w * s
    ax = L / 2 * (wd * c - w**2 * s)
    ay = L / 2 * (wd * s + w**2 * c)
    lam = {"hinge.v1.lambda": m * ax, "hinge.v2.lambda": m * ay, "hinge.v3.lambda": Z(n),
           "hinge.w1.lambda": Z(n), "hinge.w2.lambda": Z(n)}
    psiT = al * ts**2
    ls = m * L / 2 * np.sqrt(al**2 + (al * ts)**4)      # largest |F|, at t = T/2-: alpha and omega_max
    return st, lam, {"motor": np.where(tt < ts, tm, -tm)}, dict(junctions=[ts], objective=-psiT, load_scale=ls)


_SHAFT_CACHE = {}


def _shaft_solve(rtol):
    P = PARAMS["shaft"]
    m, k, r0, T = P["m"], P["k"], P["r0"], P["T"]

    def f(t, z):
        r, v, l1, l2 = z
        Om2 = Omega_np(t, P)**2
        u = -l2 / (2 * m)
        return [v, r * Om2 - k / m * (r - r0) + u / m, -l2 * (Om2 - k / m), -l1]

    def shoot(l0):
        return solve_ivp(f, (0, T), [P["ra"], 0.0, l0[0], l0[1]], method="DOP853", rtol=rtol, atol=rtol * 1e-1,
                         dense_output=True)
    base = shoot([0.0, 0.0]).y[:, -1]
    A = np.column_stack([shoot(e).y[:, -1] - base for e in ([1.0, 0.0], [0.0, 1.0])])[:2]
    l0 = np.linalg.solve(A, np.array([P["rb"], 0.0]) - base[:2])
    for _ in range(2):                                   # polish (linear, so one step suffices; checks residual)
        end = shoot(l0).y[:, -1]
        l0 = l0 + np.linalg.solve(A, np.array([P["rb"], 0.0]) - end[:2])
    sol = shoot(l0)
    return sol, l0


def shaft(tt, rtol=1e-13, **kw):
    P = PARAMS["shaft"]
    if rtol not in _SHAFT_CACHE:
        _SHAFT_CACHE[rtol] = _shaft_solve(rtol)
    sol, l0 = _SHAFT_CACHE[rtol]
    m, k, r0, M, g = P["m"], P["k"], P["r0"], P["M"], G
    r, v, l1, l2 = sol.sol(tt)
    u = -l2 / (2 * m)
    Om = Omega_np(tt, P)
    Omd = P["W1"] * P["w"] * np.cos(P["w"] * tt)
    phi = P["W0"] * tt + P["W1"] / P["w"] * (1 - np.cos(P["w"] * tt))
    a_r = r * Om**2 - k / m * (r - r0) + u / m            # r''
    c, s = np.cos(phi), np.sin(phi)
    n = len(tt)
    st = {}
    _zero_body(st, "table", n)
    _zero_body(st, "slider", n)
    for b in ("table", "slider"):
        st[f"{b}.psi"], st[f"{b}.psi_dot"], st[f"{b}.omega_z"] = phi, Om, Om
    st["slider.x"], st["slider.y"] = r * c, r * s
    st["slider.vbar_x"] = v * c - r * Om * s
    st["slider.vbar_y"] = v * s + r * Om * c
    It3, Is3 = P["It"][2], P["Is"][2]
    n1 = m * (r * Omd + 2 * v * Om)                      # rail force on the slider along the table's e2
    tau = (It3 + Is3 + m * r**2) * Omd + 2 * m * r * v * Om
    Fa = m * (a_r - r * Om**2)                            # = u - k (r - r0): applied on the slider along e1
    # hinge force on the table: F_h = F_rail(on slider) + F_applied(on slider) + M g z
    Fx = Fa * c - n1 * s
    Fy = Fa * s + n1 * c
    lam = {"motor.drive.lambda": tau, "rail.n1.lambda": n1, "rail.n2.lambda": np.full(n, m * g),
           "rail.w1.lambda": Z(n), "rail.w2.lambda": Z(n), "rail.w3.lambda": Is3 * Omd,
           "hinge.v1.lambda": Fx, "hinge.v2.lambda": Fy, "hinge.v3.lambda": np.full(n, (m + M) * g),
           "hinge.w1.lambda": r * m * g * s, "hinge.w2.lambda": -r * m * g * c}
    obj_t = np.linspace(0, P["T"], 20001)
    uu = -sol.sol(obj_t)[3] / (2 * m)
    J = np.trapezoid(uu**2, obj_t) if hasattr(np, "trapezoid") else np.trapz(uu**2, obj_t)
    ls = max(np.abs(np.vstack(list(lam.values()))).max(), 1.0) if n > 1 else None
    return st, lam, {"u": u}, dict(junctions=[], objective=J, load_scale=ls, l0=l0.tolist())


def evaluate(name, tt, **kw):
    return {"fuel": fuel, "mayer": mayer, "shaft": shaft}[name](np.asarray(tt, float), **kw)


if __name__ == "__main__":
    name = sys.argv[1] if len(sys.argv) > 1 else "shaft"
    tt = np.linspace(0, PARAMS[name]["T"], 4001)
    st, lam, inp, info = evaluate(name, tt)
    print(name, {k: v for k, v in info.items()})
    if name == "shaft":
        st2, lam2, inp2, info2 = evaluate(name, tt, rtol=1e-11)
        ds = max(np.abs(st[k] - st2[k]).max() for k in st)
        dl = max(np.abs(lam[k] - lam2[k]).max() for k in lam) / info["load_scale"]
        du = np.abs(inp["u"] - inp2["u"]).max() / np.abs(inp["u"]).max()
        print(f"rtol 1e-13 vs 1e-11: states {ds:.2e}, multipliers {dl:.2e} (of load scale {info['load_scale']:.4f}),"
              f" input {du:.2e}; r(T) = {st['slider.x'][-1] / np.cos(st['table.psi'][-1]):.14f}")
        P = PARAMS["shaft"]
        # residual check of the radial equation by finite differences of the dense solution
        sol, l0 = _SHAFT_CACHE[1e-13]
        r = sol.sol(tt)[0]
        h = tt[1] - tt[0]
        rdd = (r[2:] - 2 * r[1:-1] + r[:-2]) / h**2
        Om = Omega_np(tt[1:-1], P)
        res = P["m"] * (rdd - r[1:-1] * Om**2) - (inp["u"][1:-1] - P["k"] * (r[1:-1] - P["r0"]))
        print(f"radial equation residual by 2nd differences (h = {h:.1e}): {np.abs(res).max():.2e}")
        print(f"u range {inp['u'].min():.4f} .. {inp['u'].max():.4f}; torque range "
              f"{lam['motor.drive.lambda'].min():.4f} .. {lam['motor.drive.lambda'].max():.4f}")
