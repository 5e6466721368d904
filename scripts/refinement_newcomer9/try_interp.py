"""What a newcomer tries first for a sampled reference in problem.track (the reference is called with the
CasADi time symbol, not with numbers). Each try: one fixed-mesh solve, Radau(20, degree=5), and one
solve(tolerance=1e-4); prints what happened.

    python try_interp.py
"""
import warnings

import casadi as ca
import numpy as np
from scipy.interpolate import CubicSpline

import nc9
import ocp_constraints as oc

TK = nc9.TK
RK = nc9.r_smooth(TK)
CS = CubicSpline(TK, RK)


def attempt(label, ref):
    model = oc.Model("rod", gravity=(0.0, -9.81, 0.0))     # the rod of nc9.build, without its track term
    rod = model.add_body("rod", 1.0, 1.0 / 12 * np.diag([1.0, 0.0, 1.0]), rotation="321")
    oc.joints.revolute(model, "hinge", rod.point("A", [0.0, 0.5, 0.0]), axis=(0, 0, 1))
    model.add_torque("motor", rod, ca.vertcat(0, 0, model.add_input("motor")))
    model_problem = oc.OptimalControlProblem(model, t_final=2.0)
    model_problem.initial({"rod.psi": 0.0, "rod.psi_dot": 0.0})
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            value = ref(ca.SX.sym("t"))
            print(f"{label}: reference(SX t) -> {type(value).__name__} {str(value)[:80]!r}")
            model_problem.track("rod.psi", ref, 1000.0)
            model_problem.minimize_effort(["motor"])
            for how, kw in (("Radau(20, 5)", dict(method=oc.Radau(20, degree=5))), ("tolerance=1e-4", dict(tolerance=1e-4))):
                try:
                    sol = model_problem.solve(**kw)
                    print(f"   {how}: {sol.status}, J = {sol.objective:.10f}")
                except Exception as e:
                    print(f"   {how}: {type(e).__name__}: {str(e)[:400]}")
        except Exception as e:
            print(f"   raised {type(e).__name__}: {str(e)[:400]}")
    for w in caught:
        print(f"   warning {w.category.__name__}: {str(w.message).strip().splitlines()[0][:150]}")


attempt("np.interp(t, tk, rk)", lambda t: np.interp(t, TK, RK))
attempt("ca.interpolant('r', 'linear', [tk], rk)", (lambda f: lambda t: f(t))(ca.interpolant("r", "linear", [TK], RK)))
attempt("ca.pw_lin(t, tk, rk)", lambda t: ca.pw_lin(t, ca.DM(TK), ca.DM(RK)))
attempt("scipy CubicSpline(tk, rk) passed as is", lambda t: CS(t))
attempt("ca.interpolant('r', 'bspline', [tk], rk) (CasADi's own cubic)", (lambda f: lambda t: f(t))(ca.interpolant("r", "bspline", [TK], RK)))
