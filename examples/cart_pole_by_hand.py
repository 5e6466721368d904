"""A cart-pole swing-up written from scratch: two bodies, a rail and a hinge as constraints.

The cart slides on a rail along E1 (its center stays on the E1 axis, it does not turn); the
pole hangs from the cart at the hinge point A and turns about E3. One input pushes the cart.
From rest, pole hanging, to rest, pole upright, cart back where it started, in T = 2 s,
minimum integral of the push squared. Every constraint is written by hand as
``pi = f . v_C + h . omega + e`` (paper eq. 25); the toolkit derives the rail's and the
hinge's forces and moments. Only the coordinates the problem is about get initial and final
values: the rest follow from the constraints (the guess completes them), and the solver
says before it starts if something is left undetermined.

    python examples/cart_pole_by_hand.py
"""
import math

import casadi as ca
import numpy as np

import ocp_constraints as oc

m_cart, m_pole, L = 1.0, 0.5, 1.0
model = oc.Model("cart_pole", gravity=(0.0, -9.81, 0.0))
cart = model.add_body("cart", m_cart, np.diag([0.01, 0.01, 0.01]), rotation="321")
pole = model.add_body("pole", m_pole, m_pole * L**2 / 12 * np.diag([1.0, 0.0, 1.0]), rotation="321")
E1, E2, E3 = (ca.DM([1, 0, 0]), ca.DM([0, 1, 0]), ca.DM([0, 0, 1]))

# The rail: the cart's center moves along E1 only and the cart does not turn.
model.add_constraint("rail.v2", ca.dot(E2, cart.com.v), joint="rail", position=cart.com.position[1])
model.add_constraint("rail.v3", ca.dot(E3, cart.com.v), joint="rail", position=cart.com.position[2])
for k, E in enumerate((E1, E2, E3)):
    model.add_constraint(f"rail.w{k + 1}", ca.dot(E, cart.omega), joint="rail")

# The hinge: the pole's end A moves with the cart's center, the pole turns about E3 only.
A = pole.point("A", (0.0, L / 2, 0.0))
for k, E in enumerate((E1, E2, E3)):
    model.add_constraint(f"hinge.v{k + 1}", ca.dot(E, A.v) - ca.dot(E, cart.com.v), joint="hinge",
                         position=A.position[k] - cart.com.position[k])
model.add_constraint("hinge.w1", ca.dot(E1, pole.omega - cart.omega), joint="hinge")
model.add_constraint("hinge.w2", ca.dot(E2, pole.omega - cart.omega), joint="hinge")

push = model.add_input("push")
model.add_force("push", cart.com, ca.vertcat(push, 0, 0))

ocp = oc.OptimalControlProblem(model, t_final=2.0)
ocp.initial({"cart.x": 0.0, "cart.psi": 0.0, "cart.theta": 0.0, "cart.phi": 0.0,
             "pole.psi": 0.0, "pole.theta": 0.0, "pole.phi": 0.0})
ocp.final({"cart.x": 0.0, "pole.psi": math.pi})
for name in ("cart.vbar_x", "pole.omega_z"):
    ocp.initial({name: 0.0})
    ocp.final({name: 0.0})
ocp.bound("push", -40.0, 40.0)
ocp.minimize_effort(["push"])

if __name__ == "__main__":       # the model and problem alone where another script loads this one (runpy)
    sol = ocp.solve(oc.Radau(30, degree=3))
    print(f"{sol.status} in {sol.iterations} iterations, objective {sol.objective:.6f}")
    print(f"largest hinge force {np.abs(sol.loads()['hinge@pole.F_y']).max():.3f} N")
