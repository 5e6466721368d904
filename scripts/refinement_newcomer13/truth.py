"""Independent references, by name: ref(name, t) -> (states, loads, inputs), dicts of arrays at times t (s).

vehicle / vehicle_free and spring: closed forms (below). fivebar / fivebar_free: own minimal-coordinate collocation
(fivebar_ref.py, stored in ref_fivebar*.pkl).

Loads are joint forces/moments on the body, fixed basis, keyed '<channel>.F_x' ... '.M_z' (the library's
``problem.joint_force`` / moments are evaluated from its interpolated multipliers and coordinates in run.py).
"""
from __future__ import annotations

import math

import numpy as np

from models import FB, G, SPR, VEH


def vehicle_free(t):
    p = VEH
    m, D, T = p["m"], p["D"], p["T"]
    s = np.asarray(t) / T
    x = D * (3 * s**2 - 2 * s**3)
    v = 6 * D / T * s * (1 - s)
    a = 6 * D / T**2 * (1 - 2 * s)
    return x, v, m * a


def vehicle_bounded(t):
    """Speed bound vmax active on [t1, T - t1]: t1 = 3 (T - D / vmax) / 2 (= 5 s); on the outer arcs a linear
    force vanishing at the junction (a(t1) = 0), c = 2 vmax / t1^2."""
    p = VEH
    m, D, T, vm = p["m"], p["D"], p["T"], p["vmax"]
    t1 = 1.5 * (T - D / vm)
    c = 2 * vm / t1**2
    t = np.asarray(t, float)

    def ph1(t):
        return c * (t1 * t**2 / 2 - t**3 / 6), c * (t1 * t - t**2 / 2), c * (t1 - t)
    x = np.empty_like(t)
    v = np.empty_like(t)
    a = np.empty_like(t)
    A, B, C = t <= t1, (t > t1) & (t < T - t1), t >= T - t1
    x[A], v[A], a[A] = ph1(t[A])
    x1 = 2 * vm * t1 / 3
    x[B], v[B], a[B] = x1 + vm * (t[B] - t1), vm, 0.0
    xr, vr, ar = ph1(T - t[C])
    x[C], v[C], a[C] = D - xr, vr, -ar
    return x, v, m * a


def vehicle_junctions():
    p = VEH
    t1 = 1.5 * (p["T"] - p["D"] / p["vmax"])
    return [t1, p["T"] - t1]


def spring(t):
    """Minimum-energy control of x'' = -w^2 x + u/m from rest at 0 to (xT, vT) at T: u(t) = B^T e^{A^T (T-t)} eta,
    eta = W(T)^-1 (x_T - e^{AT} x0), x(t) = W(t) e^{A^T (T-t)} eta (x0 = 0), Gramian W(t) in closed form."""
    p = SPR
    m, w, T = p["m"], p["omega"], p["T"]
    t = np.asarray(t, float)

    def W(t):
        ss = t / 2 - np.sin(2 * w * t) / (4 * w)
        cc = t / 2 + np.sin(2 * w * t) / (4 * w)
        sc = np.sin(w * t) ** 2 / (2 * w)
        return np.array([[ss / w**2, sc / w], [sc / w, cc]]) / m**2

    def expAT(tau):   # e^{A^T tau}, A = [[0,1],[-w^2,0]]
        c, s = np.cos(w * tau), np.sin(w * tau)
        return np.array([[c, -w * s], [s / w, c]])   # transpose of [[c, s/w], [-w s, c]]
    eta = np.linalg.solve(W(T), np.array([p["xT"], p["vT"]]))
    lam = np.einsum("ijn,j->in", expAT(T - t), eta)   # 2 x n : e^{A^T(T-t)} eta
    Wt = W(t)                                          # 2 x 2 x n
    X = np.einsum("ijn,jn->in", Wt, lam)
    u = lam[1] / m                                     # B^T = [0, 1/m]
    return X[0], X[1], u


def ref(name, t):
    t = np.asarray(t, float)
    z = np.zeros_like(t)
    if name.startswith("vehicle"):
        x, v, F = (vehicle_free if name == "vehicle_free" else vehicle_bounded)(t)
        m = VEH["m"]
        st = {"car.x": x, "car.vbar_x": v}
        st.update({k: z for k in ("car.y", "car.z", "car.psi", "car.theta", "car.phi", "car.vbar_y", "car.vbar_z",
                                  "car.omega_x", "car.omega_y", "car.omega_z")})
        loads = {"rail.F_x": z, "rail.F_y": z + m * G, "rail.F_z": z, "rail.M_x": z, "rail.M_y": z, "rail.M_z": z}
        return st, loads, {"drive": F}
    if name == "spring":
        x, v, u = spring(t)
        m = SPR["m"]
        st = {"block.x": x, "block.vbar_x": v}
        st.update({k: z for k in ("block.y", "block.z", "block.psi", "block.theta", "block.phi", "block.vbar_y",
                                  "block.vbar_z", "block.omega_x", "block.omega_y", "block.omega_z")})
        loads = {"rail.F_x": z, "rail.F_y": z + m * G, "rail.F_z": z, "rail.M_x": z, "rail.M_y": z, "rail.M_z": z}
        return st, loads, {"push": u}
    if name.startswith("fivebar"):
        import fivebar_ref
        return fivebar_ref.Stored(name).quantities(t)
    raise SystemExit(name)


def junctions(name):
    if name == "fivebar_other":
        return []
    if name == "vehicle":
        return vehicle_junctions()
    if name.startswith("fivebar"):
        import fivebar_ref
        return fivebar_ref.Stored(name).junctions
    return []


def uncertainty(name):
    if name.startswith("fivebar"):
        import fivebar_ref
        return fivebar_ref.Stored(name).uncertainty
    return "closed form"


if __name__ == "__main__":
    # self-checks of the closed forms
    t = np.linspace(0, VEH["T"], 200001)
    x, v, F = vehicle_bounded(t)
    print("vehicle: x(T)", x[-1], "max v", v.max(), "J", np.trapezoid(F**2, t), "expected 1.10592e8",
          "x continuity", np.abs(np.diff(x)).max(), "dx/dt - v", np.abs(np.gradient(x, t) - v)[1:-1].max())
    t = np.linspace(0, SPR["T"], 500001)
    x, v, u = spring(t)
    w, m = SPR["omega"], SPR["m"]
    a = np.gradient(v, t)
    print("spring: x(0), v(0)", x[0], v[0], "x(T), v(T)", x[-1], v[-1], "max|u|", np.abs(u).max(),
          "dx/dt - v", np.abs(np.gradient(x, t) - v)[1:-1].max(), "ode resid", np.abs(m * a + m * w**2 * x - u)[1:-1].max(),
          "J", np.trapezoid(u**2, t))
