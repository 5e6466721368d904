"""The two problems of newcomer check 7, written through the public API only (import ocp_constraints as oc).

Both: a planar two-link arm (L1 0.5 m, m1 1 kg, L2 0.4 m, m2 0.8 kg, slender rods, gravity -y), from hanging at rest
(q = (-pi/2, 0)) to rest at q = (pi/4, pi/3) (q2 relative, the elbow) in T = 1 s.
1. urdf_arm: the arm loaded from arm2.urdf (oc.load_urdf, base="ground"), least effort, |shoulder.tau| <= 4.5
   (active on one arc); urdf_free: the same without the bound (probes only).
2. load_arm: the same arm by hand (two bodies, revolute "shoulder" to the ground and "elbow" between the links),
   min int |tau|^2 + 0.05 int (elbow.v1^2 + elbow.v2^2) via minimize_load_effort (the elbow pin's force).
"""
import math, os
import casadi as ca
import numpy as np
import ocp_constraints as oc

G = 9.81
HERE = os.path.dirname(os.path.abspath(__file__))
ARM = dict(L1=0.5, m1=1.0, L2=0.4, m2=0.8, T=1.0, q0=(-math.pi / 2, 0.0), qf=(math.pi / 4, math.pi / 3),
           tau1_max=None, w_load=0.0)


def rod_inertia(m, L):
    return np.diag([1e-4, m * L ** 2 / 12, m * L ** 2 / 12])


def smooth(s):
    s = np.clip(np.asarray(s, float), 0, 1)
    return 3 * s ** 2 - 2 * s ** 3


def urdf_arm(p):
    robot = oc.load_urdf(os.path.join(HERE, "arm2.urdf"), base="ground", gravity=(0.0, -G, 0.0))
    pr = oc.OptimalControlProblem(robot.model, t_final=p["T"])
    qa, qb = np.array(p["q0"]), np.array(p["qf"])
    robot.set_boundary(pr, "initial", qa)
    robot.set_boundary(pr, "final", qb)
    robot.set_guess(pr, lambda s: qa + (qb - qa) * smooth(s)[:, None])
    if p["tau1_max"] is not None:
        pr.bound("shoulder.tau", -p["tau1_max"], p["tau1_max"])
    pr.minimize_effort()
    return pr


def load_arm(p):
    model = oc.Model("two_link_load", gravity=(0.0, -G, 0.0))
    l1 = model.add_body("link1", p["m1"], rod_inertia(p["m1"], p["L1"]), rotation="321")
    l2 = model.add_body("link2", p["m2"], rod_inertia(p["m2"], p["L2"]), rotation="321")
    oc.joints.revolute(model, "shoulder", l1.point("O", (-p["L1"] / 2, 0, 0)), axis=(0, 0, 1), anchor=(0, 0, 0))
    oc.joints.revolute(model, "elbow", l2.point("E", (-p["L2"] / 2, 0, 0)), axis=(0, 0, 1),
                       other=l1.point("E", (p["L1"] / 2, 0, 0)))
    t1, t2 = model.add_input("tau1"), model.add_input("tau2")
    model.add_torque("shoulder_motor", l1, ca.vertcat(0, 0, t1))
    model.add_torque("elbow_motor", l2, ca.vertcat(0, 0, t2))
    model.add_torque("elbow_reaction", l1, ca.vertcat(0, 0, -t2))
    pr = oc.OptimalControlProblem(model, t_final=p["T"])
    (a0, b0), (a1, b1) = p["q0"], p["qf"]
    pr.initial({"link1.psi": a0, "link1.omega_z": 0.0, "link2.psi": a0 + b0, "link2.omega_z": 0.0})
    pr.final({"link1.psi": a1, "link1.omega_z": 0.0, "link2.psi": a1 + b1, "link2.omega_z": 0.0})
    pr.minimize_effort()
    pr.minimize_load_effort(["elbow.v1", "elbow.v2"], [p["w_load"], p["w_load"]])
    s = lambda t: smooth(np.asarray(t) / p["T"])
    q1 = lambda t: a0 + (a1 - a0) * s(t)
    q12 = lambda t: a0 + b0 + (a1 + b1 - a0 - b0) * s(t)
    pr.set_guess("link1.psi", q1)
    pr.set_guess("link2.psi", q12)
    pr.set_guess("link1.x", lambda t: p["L1"] / 2 * np.cos(q1(t)))
    pr.set_guess("link1.y", lambda t: p["L1"] / 2 * np.sin(q1(t)))
    pr.set_guess("link2.x", lambda t: p["L1"] * np.cos(q1(t)) + p["L2"] / 2 * np.cos(q12(t)))
    pr.set_guess("link2.y", lambda t: p["L1"] * np.sin(q1(t)) + p["L2"] / 2 * np.sin(q12(t)))
    return pr


DEFAULT = ["urdf_arm", "urdf_arm@r3n40", "load_arm"]      # what `python nc7.py all` runs without names
VARIANTS = {
    "urdf_free": ("urdf_arm", ARM, {}),
    "urdf_arm": ("urdf_arm", dict(ARM, tau1_max=4.5), {}),
    "load_arm": ("load_arm", dict(ARM, w_load=0.05), {}),
}


def variant(name):
    return VARIANTS[name]


def build(name):
    base, p, kw = VARIANTS[name]
    return globals()[base](p, **kw)

# The report's section titles (python report.py).
REPORT_NAMES = {"urdf_arm@r3n40": "1. URDF two-link arm (arm2.urdf, oc.load_urdf), rest to rest, least effort, |shoulder.tau| <= 4.5 (one arc), refined from Radau 3 x 40",
         "urdf_arm": "1b. the same from the default start (solve(tolerance=tol))",
         "load_arm": "2. two-link arm by hand, min effort + 0.05 minimize_load_effort([elbow.v1, elbow.v2]), default start (the optimum it finds, objective 31.224)",
         "load_arm@r5n40": "2b. the same refined from Radau 5 x 40 (the better optimum, objective 13.946)"}
