"""The numbers of the user-problem suite (SI units), shared by both formulations of each problem.

Our side (:mod:`.ocp_suite`, :mod:`.ocp_suite_3d`) writes every problem with bodies and
constraints; the minimal-coordinate side (:mod:`.ocp_suite_minimal`) derives each problem's
equations of motion by hand. Only these numbers are shared, never code.
"""
from __future__ import annotations

G = 9.81

# Two uniform rods hinged at the origin (shoulder, passive) and to each other (elbow, motor).
ACROBOT = {"m1": 1.0, "m2": 1.0, "l1": 1.0, "l2": 1.0, "T": 4.0, "tau_max": 20.0}

# A cart on a rail along E1, pushed by a bounded force, carrying two uniform rods in a chain.
CART_DOUBLE = {"m0": 1.0, "m1": 0.5, "m2": 0.5, "l1": 0.5, "l2": 0.5, "T": 2.5, "f_max": 60.0, "x_max": 1.5}

# Crank (a) driven about O, coupler (b), rocker (c) hinged at D = (d, 0); uniform rods of
# line density rho. The crank makes one turn, rest to rest, with the pin force at B bounded.
FOUR_BAR = {"a": 0.3, "b": 1.0, "c": 0.8, "d": 1.0, "rho": 1.0, "T": 1.0, "f_pin_max": 18.0}

# Thin disk rolling on a rough plane, torques (fixed basis) applied to it, friction cone mu.
DISK = {"m": 1.5, "R": 0.2, "T": 1.2, "mu": 0.2, "x": 0.6, "y": 0.3, "psi": 0.8}

# Quadrotor (arm length ``arm``, drag-to-thrust ratio ``k``) with a small ball hanging on a
# massless rod of length ``L`` from a hook ``hook`` below its center; four rotor thrusts.
QUAD = {"M": 1.0, "Ixx": 0.01, "Iyy": 0.01, "Izz": 0.02, "arm": 0.2, "k": 0.02, "m_load": 0.3, "r_load": 0.05,
        "L": 0.5, "hook": 0.05, "T": 3.0, "x": 2.0, "y": 1.0, "z": 0.5, "f_max": 8.0}

# Planar five-link walker: stance shank, stance thigh, torso, swing thigh, swing shank; the stance
# foot (half length ``foot``) on the ground: normal force >= 0, friction cone mu, center of pressure
# on the foot (|ankle torque| <= foot * normal force); the swing foot above the ground; knees
# flex only forwards. Lean angles of the links (upper end towards +E1, rad): the stance leg keeps
# its posture; the swing leg, slightly flexed, goes from (thigh, shank) = (swing_thigh, swing_shank)
# behind to (-swing_shank, -swing_thigh) ahead, its foot 8 mm above the ground; rest to rest.
WALKER = {"m_torso": 10.0, "l_torso": 0.6, "m_thigh": 5.0, "l_thigh": 0.5, "m_shank": 3.0, "l_shank": 0.5,
          "T": 0.8, "mu": 0.6, "foot": 0.1, "stance_shank": 0.3, "stance_thigh": -0.3, "torso": 0.0,
          "swing_thigh": 0.3, "swing_shank": 0.35}
