"""The four problems of newcomer check 6, written through the public API only (import ocp_constraints as oc).

1. fourbar: a planar four-bar (crank, coupler, rocker; pins to ground at O and D), crank turned 0 -> pi rest to rest
   by a crank torque, min int tau^2 + w int |F_O|^2 (the ground pin O's force, problem.joint_force).
2. sph: a rod on a ball-and-socket joint (quaternion coordinates), three fixed-basis torques turn it from hanging at
   rest to rest at the 3-2-1 angles (0.6, 0.4, 0.9), min int |tau|^2.
3. sleigh: a Chaplygin sleigh (planar joint to the floor + a knife edge at C behind the centre, written by hand as
   e2 . v_C = 0), forward force at C and a torque, from rest at the origin to rest at (2, 1, 0), min effort.
4. track: a pendulum tracking psi_ref(t) = -pi/2 + A sin(w t) (explicit time in the integrand) with a small effort
   term; |tau| <= tau_max is active on arcs.
"""
import math
import casadi as ca
import numpy as np
import ocp_constraints as oc

G = 9.81


def rod_inertia(m, L):
    """A slender rod along its body x axis (the psi = 0 direction), turning about z."""
    return np.diag([1e-4, m * L ** 2 / 12, m * L ** 2 / 12])


# ---------------------------------------------------------------- 1. four-bar, effort + ground pin load
FB = dict(a=0.2, b=0.6, c=0.5, d=0.6, rho=2.0, T=1.5, theta_f=math.pi, w_load=0.02)


def fourbar_angles(theta, p=FB):
    """Coupler and rocker angles for crank angle theta (numpy), the branch with B above the line A-D."""
    A = np.array([p["a"] * np.cos(theta), p["a"] * np.sin(theta)])
    theta = np.asarray(theta, float)
    D = np.array([p["d"] + 0.0 * theta, 0.0 * theta])
    dlt = D - A
    L = np.hypot(*dlt)
    along = (p["b"] ** 2 - p["c"] ** 2 + L ** 2) / (2 * L)
    h = np.sqrt(p["b"] ** 2 - along ** 2)
    u = dlt / L
    perp = np.array([-u[1], u[0]])
    B = A + along * u + h * perp
    return np.arctan2(B[1] - A[1], B[0] - A[0]), np.arctan2(B[1] - D[1], B[0] - D[0])


def fourbar(p=FB, coordinates="auto"):
    model = oc.Model("four_bar_load", gravity=(0.0, -G, 0.0))
    bars = {}
    for name, length in (("crank", p["a"]), ("coupler", p["b"]), ("rocker", p["c"])):
        m = p["rho"] * length
        bars[name] = model.add_body(name, m, rod_inertia(m, length), rotation="321")
    crank, coupler, rocker = bars["crank"], bars["coupler"], bars["rocker"]
    oc.joints.revolute(model, "O", crank.point("O", (-p["a"] / 2, 0, 0)), axis=(0, 0, 1), anchor=(0, 0, 0))
    oc.joints.revolute(model, "A", coupler.point("A", (-p["b"] / 2, 0, 0)), axis=(0, 0, 1),
                       other=crank.point("A", (p["a"] / 2, 0, 0)))
    oc.joints.revolute(model, "D", rocker.point("D", (-p["c"] / 2, 0, 0)), axis=(0, 0, 1), anchor=(p["d"], 0, 0))
    # the loop's last pin: point on line along z (a pin of revolute joints only is over-constrained in space)
    oc.joints.point_on_line(model, "B", rocker.point("B", (p["c"] / 2, 0, 0)),
                            other=coupler.point("B", (p["b"] / 2, 0, 0)), axis=(0, 0, 1))
    model.add_torque("motor", crank, ca.vertcat(0, 0, model.add_input("tau")))
    pr = oc.OptimalControlProblem(model, t_final=p["T"], coordinates=coordinates)
    pr.initial({"crank.psi": 0.0, "crank.psi_dot": 0.0})
    pr.final({"crank.psi": p["theta_f"], "crank.psi_dot": 0.0})
    pr.minimize_effort()
    F = pr.joint_force("O")
    pr.minimize_integral(ca.sumsqr(F), weight=p["w_load"], label="ground pin O load")
    th = lambda t: p["theta_f"] * (np.asarray(t) / p["T"])
    pr.set_guess("crank.psi", th)
    pr.set_guess("coupler.psi", lambda t: fourbar_angles(th(t), p)[0])
    pr.set_guess("rocker.psi", lambda t: fourbar_angles(th(t), p)[1])
    return pr


# ---------------------------------------------------------------- 2. rod on a ball-and-socket joint (quaternion)
SP = dict(m=1.0, L=1.0, T=2.0, final_321=(0.6, 0.4, 0.9))


def quat_321(psi, theta, phi):
    """Unit quaternion (w, x, y, z) of R = R3(psi) R2(theta) R1(phi)."""
    cy, sy = math.cos(psi / 2), math.sin(psi / 2)
    cp, sp = math.cos(theta / 2), math.sin(theta / 2)
    cr, sr = math.cos(phi / 2), math.sin(phi / 2)
    return (cr * cp * cy + sr * sp * sy, sr * cp * cy - cr * sp * sy, cr * sp * cy + sr * cp * sy,
            cr * cp * sy - sr * sp * cy)


def sph(p=SP):
    m, L = p["m"], p["L"]
    model = oc.Model("ball_socket_rod", gravity=(0.0, 0.0, -G))
    bob = model.add_body("bob", m, np.diag([m * L ** 2 / 12, m * L ** 2 / 12, 0.01]), rotation="quaternion")
    oc.joints.ball_and_socket(model, "socket", bob.point("P", (0.0, 0.0, L / 2)), anchor=(0, 0, 0))
    tau = ca.vertcat(*[model.add_input(f"t{c}") for c in "xyz"])
    model.add_torque("motor", bob, tau)   # fixed basis
    pr = oc.OptimalControlProblem(model, t_final=p["T"])
    rest = {"bob.omega_x": 0.0, "bob.omega_y": 0.0, "bob.omega_z": 0.0}
    qf = tuple(p.get("qsign", 1) * v for v in quat_321(*p["final_321"]))   # qsign -1: the same pose as -q
    pr.initial({"bob.qw": 1.0, "bob.qx": 0.0, "bob.qy": 0.0, "bob.qz": 0.0, **rest})
    pr.final({"bob.qw": qf[0], "bob.qx": qf[1], "bob.qy": qf[2], "bob.qz": qf[3], **rest})
    pr.minimize_effort()
    # guess: slerp from the identity to qf, the centre below the socket
    ang = 2 * math.acos(qf[0]); axis = np.array(qf[1:]) / math.sin(ang / 2)
    def quat(t):
        s = np.asarray(t, float) / p["T"]
        return np.cos(s * ang / 2), *(np.sin(s * ang / 2)[None, :] * axis[:, None])
    def centre(t, k):
        w, x, y, z = quat(t)
        col = np.array([2 * (x * z + y * w), 2 * (y * z - x * w), 1 - 2 * (x * x + y * y)])   # R e3
        return -L / 2 * col[k]
    for k, nm in enumerate(("qw", "qx", "qy", "qz")):
        pr.set_guess(f"bob.{nm}", lambda t, k=k: np.asarray(quat(t)[k], float))
    for k, nm in enumerate("xyz"):
        pr.set_guess(f"bob.{nm}", lambda t, k=k: centre(t, k))
    return pr


# ---------------------------------------------------------------- 3. Chaplygin sleigh (knife edge by hand)
SL = dict(m=2.0, I=0.1, a=0.3, T=4.0, target=(2.0, 1.0, 0.0))


def sleigh(p=SL):
    model = oc.Model("sleigh", gravity=(0.0, 0.0, 0.0))
    body = model.add_body("sleigh", p["m"], np.diag([0.05, 0.05, p["I"]]), rotation="321")
    oc.joints.planar(model, "floor", body.com, normal=(0, 0, 1))
    C = body.point("C", (-p["a"], 0.0, 0.0))
    model.add_constraint("knife", ca.dot(body.e(2), C.v), joint="knife")   # no sideways velocity at the blade
    F, tau = model.add_input("F"), model.add_input("tau")
    model.add_force("push", C, F * body.e(1))
    model.add_torque("steer", body, ca.vertcat(0, 0, tau))
    pr = oc.OptimalControlProblem(model, t_final=p["T"])
    x1, y1, psi1 = p["target"]
    rest = {"sleigh.vbar_x": 0.0, "sleigh.omega_z": 0.0}
    pr.initial({"sleigh.x": 0.0, "sleigh.y": 0.0, "sleigh.psi": 0.0, **rest})
    pr.final({"sleigh.x": x1, "sleigh.y": y1, "sleigh.psi": psi1, **rest})
    pr.minimize_effort()
    pr.set_guess("sleigh.x", lambda t: x1 * np.asarray(t) / p["T"])
    pr.set_guess("sleigh.y", lambda t: y1 * np.asarray(t) / p["T"])
    return pr


# ---------------------------------------------------------------- 4. pendulum tracking a time-varying angle
TR = dict(m=1.0, L=1.0, T=1.5, A=0.8, w=2 * math.pi, W=10.0, w_eff=0.1, tau_max=2.5)


def track(p=TR):
    model = oc.Model("pendulum_tracking", gravity=(0.0, -G, 0.0))
    r = model.add_body("rod", p["m"], rod_inertia(p["m"], p["L"]), rotation="321")
    oc.joints.revolute(model, "hinge", r.point("P", (-p["L"] / 2, 0, 0)), axis=(0, 0, 1), anchor=(0, 0, 0))
    model.add_torque("motor", r, ca.vertcat(0, 0, model.add_input("tau")))
    pr = oc.OptimalControlProblem(model, t_final=p["T"])
    pr.initial({"rod.psi": -math.pi / 2, "rod.omega_z": 0.0})
    pr.bound("tau", -p["tau_max"], p["tau_max"])
    ref = -math.pi / 2 + p["A"] * ca.sin(p["w"] * model.t)
    pr.minimize_integral((pr.quantity("rod.psi") - ref) ** 2, weight=p["W"], label="tracking")
    pr.minimize_effort(weight=p["w_eff"])
    pr.set_guess("rod.psi", lambda t: -math.pi / 2 + p["A"] * np.sin(p["w"] * np.asarray(t)))
    return pr


# ---------------------------------------------------------------- variants (harder settings of the same four)
VARIANTS = {
    "fourbar": ("fourbar", FB, {}),
    "fourbar_max": ("fourbar", FB, {"coordinates": "maximal"}),          # the same problem in maximal coordinates
    "fourbar_turn": ("fourbar", dict(FB, T=1.2, theta_f=2 * math.pi, w_load=0.05), {}),   # a full turn, faster
    # near a toggle: AD reaches 0.93 of b + c = 0.95 at theta = pi (transmission angle 156 deg, 24 deg from toggle)
    "fourbar_toggle": ("fourbar", dict(FB, a=0.33, b=0.5, c=0.45, d=0.6, T=1.2, theta_f=2 * math.pi, w_load=0.05), {}),
    "sph": ("sph", SP, {}),
    "sph_negq": ("sph", dict(SP, qsign=-1), {}),   # the same final pose given as -q: another motion (see README)
    "sph_big": ("sph", dict(SP, T=1.5, final_321=(1.2, 0.9, -1.0)), {}),  # a larger, faster tilt
    "sleigh": ("sleigh", SL, {}),
    "sleigh_turn": ("sleigh", dict(SL, T=3.0, target=(1.0, 1.5, math.pi / 2)), {}),   # park a quarter turn sideways
    "track": ("track", TR, {}),
    "track_fast": ("track", dict(TR, A=0.3, w=12 * math.pi, tau_max=100.0), {}),   # 6 Hz reference, bound inactive
    "track_steep": ("track", dict(TR, w_eff=0.01, tau_max=5.0), {}),    # small effort: steep torque between arcs
}


def variant(name):
    """(base problem, parameter dict, builder keyword arguments) of a problem name."""
    return VARIANTS[name]


def build(name):
    base, p, kw = VARIANTS[name]
    return globals()[base](p, **kw)
