"""A user's own optimal-control problem: edits after a solve take effect, mistakes are named before
IPOPT starts, the start IPOPT gets is consistent, a load bound in the user's units costs IPOPT no more than one
scaled by hand, and Ctrl-C keeps the last iterate."""
import math
import os
import signal

import casadi as ca
import numpy as np
import pytest

import ocp_constraints as oc
from ocp_constraints.ocp.transcription import transcribe

ANGLES = ("psi", "theta", "phi")


def cart_pole(initial_angles: bool = True) -> oc.OptimalControlProblem:
    """The cart-pole of examples/cart_pole_by_hand.py, every constraint written by hand."""
    model = oc.Model("cart_pole", gravity=(0.0, -9.81, 0.0))
    cart = model.add_body("cart", 1.0, np.diag([0.01, 0.01, 0.01]), rotation="321")
    pole = model.add_body("pole", 0.5, 0.5 / 12 * np.diag([1.0, 0.0, 1.0]), rotation="321")
    E = [ca.DM.eye(3)[:, k] for k in range(3)]
    model.add_constraint("rail.v2", ca.dot(E[1], cart.com.v), joint="rail", position=cart.com.position[1])
    model.add_constraint("rail.v3", ca.dot(E[2], cart.com.v), joint="rail", position=cart.com.position[2])
    for k in range(3):
        model.add_constraint(f"rail.w{k + 1}", ca.dot(E[k], cart.omega), joint="rail")
    A = pole.point("A", (0.0, 0.5, 0.0))
    for k in range(3):
        model.add_constraint(f"hinge.v{k + 1}", ca.dot(E[k], A.v - cart.com.v), joint="hinge",
                             position=A.position[k] - cart.com.position[k])
    for k in range(2):
        model.add_constraint(f"hinge.w{k + 1}", ca.dot(E[k], pole.omega - cart.omega), joint="hinge")
    push = model.add_input("push")
    model.add_force("push", cart.com, ca.vertcat(push, 0, 0))
    ocp = oc.OptimalControlProblem(model, t_final=2.0)
    ocp.initial({"cart.x": 0.0, "pole.psi": 0.0, "cart.vbar_x": 0.0, "pole.omega_z": 0.0})
    if initial_angles:
        ocp.initial({f"{b}.{a}": 0.0 for b in ("cart", "pole") for a in ANGLES if (b, a) != ("pole", "psi")})
    ocp.final({"cart.x": 0.0, "pole.psi": math.pi, "cart.vbar_x": 0.0, "pole.omega_z": 0.0})
    ocp.bound("push", -40.0, 40.0)
    ocp.minimize_effort(["push"])
    return ocp


# -- edits after a solve ---------------------------------------------------------------------------
def test_an_objective_term_added_after_a_solve_changes_the_next_solve():
    ocp = cart_pole()
    first = ocp.solve(oc.Radau(15, degree=3))
    ocp.minimize_effort(["push"], weight=9.0)        # the objective is now 10 times the first one
    second = ocp.solve(oc.Radau(15, degree=3))
    # Scaling an objective keeps its minimizer: the optimum is 10 times the first, same motion.
    assert second.objective == pytest.approx(10 * first.objective, rel=1e-6)
    assert np.allclose(second.sample("push"), first.sample("push"), atol=1e-5)


def test_bounds_and_boundary_values_edited_after_a_solve_are_seen():
    ocp = cart_pole()
    method = oc.Radau(15, degree=3)
    first = ocp.solve(method)
    assert np.abs(first.sample("push")).max() > 12.0
    ocp.bound("push", -12.0, 12.0)
    ocp.final({"cart.x": 0.3})
    second = ocp.solve(method)
    assert np.abs(second.sample("push")).max() <= 12.0 + 1e-6
    assert second.sample("cart.x")[-1] == pytest.approx(0.3, abs=1e-8)
    assert second.objective > first.objective


def test_a_path_constraint_added_after_a_solve_holds_in_the_next_solve():
    ocp = cart_pole()
    method = oc.Radau(15, degree=3)
    first = ocp.solve(method)
    assert first.sample("cart.x").max() > 0.05
    ocp.subject_to(ocp.quantity("cart.x"), -np.inf, 0.05, "cart stays left of 5 cm")
    second = ocp.solve(method)
    assert second.sample("cart.x").max() <= 0.05 + 1e-8


def test_a_model_changed_after_the_problem_was_made_is_refused():
    ocp = cart_pole()
    ocp.model.add_input("second_push")
    with pytest.raises(oc.ModelError, match="changed after"):
        ocp.solve(oc.Radau(10, degree=3))


# -- named before IPOPT starts ----------------------------------------------------------------------
def test_undetermined_initial_values_are_named_before_any_solve():
    ocp = cart_pole(initial_angles=False)
    with pytest.raises(oc.ModelError) as info:
        ocp.solve(oc.Radau(15, degree=3))
    message = str(info.value)
    for name in ("cart.psi", "cart.theta", "cart.phi", "pole.theta", "pole.phi"):
        assert name in message
    assert "pole.psi" not in message.split("problem.initial")[0]      # it was given
    assert not getattr(ocp, "_transcriptions", {})                   # nothing was built or solved


def test_declared_free_initial_values_are_accepted():
    ocp = cart_pole(initial_angles=False)
    ocp.leave_free([f"cart.{a}" for a in ANGLES])
    with pytest.raises(oc.ModelError) as info:
        ocp.solve(oc.Radau(15, degree=3))
    assert "cart.psi" not in str(info.value) and "pole.theta" in str(info.value)


@pytest.mark.parametrize("edit, culprit", [
    (lambda p: p.initial({"cart.y": 0.2}), "rail.v2"),                       # the rail holds y = 0
    (lambda p: p.final({"pole.y": 0.7}), "hinge.v2|rail.v2"),               # farther than the pole's length
    (lambda p: p.initial({"cart.vbar_y": 1.0}), "rail.v2"),                  # the rail forbids it
    (lambda p: p.initial({"push": 99.0}), "push"),                           # outside its bounds
    (lambda p: p.set_guess("cart.x", lambda t: np.full_like(t, np.nan)), "cart.x"),
    (lambda p: p.set_guess("cart.x", lambda t: math.sin(t)), "cart.x"),      # not an array function
])
def test_inconsistent_inputs_are_named_before_any_solve(edit, culprit):
    ocp = cart_pole()
    edit(ocp)
    with pytest.raises(oc.ModelError, match=culprit.replace(".", r"\.")):  # the culprit is named
        ocp.solve(oc.Radau(10, degree=3))


def test_reversed_free_final_time_bounds_are_named():
    ocp = cart_pole()
    ocp.t_final_bounds = (3.0, 1.0)
    with pytest.raises(oc.ModelError, match="t_final_bounds"):
        ocp.solve(oc.Radau(10, degree=3))


def test_an_nlp_larger_than_the_memory_is_refused_with_the_estimate():
    with pytest.raises(oc.ModelError, match="GiB"):
        cart_pole().solve(oc.Radau(2_000_000, degree=3))


# -- a consistent start ----------------------------------------------------------------------------
def test_the_start_is_on_the_constraints():
    """From guesses of two coordinates only, every point of the start satisfies phi = 0 and G u + e = 0."""
    ocp = cart_pole()
    tr = transcribe(ocp, oc.Radau(20, degree=3))
    X, _, _, W, _, _ = (np.asarray(b) for b in tr.layout.split(tr.initial_guess()))
    e, t = tr.eqs, tr.fractions * ocp.t_final
    for i in range(len(t)):
        _, _, phi, pi, _ = (np.asarray(v) for v in e.constraint_functions(X[: e.nq, i], X[e.nq:, i], t[i], W[:, i]))
        assert np.abs(phi).max() < 1e-10 and np.abs(pi).max() < 1e-9


def test_the_start_has_no_dynamics_defect_where_the_inputs_can_produce_the_motion():
    """Pendulum swing-up (one motor, one degree of freedom: any guessed motion can be produced):
    at iteration 0 the NLP's balances M u' - f - G^T lambda - B tau are zero at every point whose
    torque stays inside the motor's bounds (|tau| <= 20 N m)."""
    _, ocp = oc.build_task("pendulum", "swing_up")
    tr = transcribe(ocp, oc.Radau(20, degree=3))
    x0 = tr.initial_guess()
    g = np.asarray(ca.Function("g", [tr.nlp["x"]], [tr.nlp["g"]])(x0)).ravel()
    _, _, _, W, _, _ = (np.asarray(b) for b in tr.layout.split(x0))
    nu, p = tr.eqs.nu, 4
    first = [tr.block.rows("point", 0)] + [tr.block.rows("collocation_point", n) for n in range(20 * (p - 1))]
    inside = np.abs(W[0]) < 20.0 - 1e-9
    assert inside.sum() >= 50
    worst = max(np.abs(g[r: r + nu]).max() for r, ok in zip(first, inside) if ok)
    assert worst < 1e-9


def test_the_user_problem_converges_from_the_completed_guess_to_the_optimum_of_both_guesses():
    """A guess of every coordinate (the pole swinging up linearly) and none at all (linear between
    boundary values) reach the same optimum."""
    with_guess = cart_pole()
    with_guess.set_guess("pole.psi", lambda t: math.pi * t / 2)
    a = with_guess.solve(oc.Radau(20, degree=3))
    b = cart_pole().solve(oc.Radau(20, degree=3))
    assert a.success and b.success
    assert a.objective == pytest.approx(b.objective, rel=1e-7)


# -- path constraints in the user's units ----------------------------------------------------------
def crane(tension_row) -> oc.OptimalControlProblem:
    """A gantry crane moves a 50 kg load 2 m in minimum time, rest to rest: trolley on a rail, load on a
    3 m rope (a hinge at the trolley), trolley force within 200 N, the rope's tension ``|F|`` within 1.05
    of the load's weight; ``tension_row(F_squared, bound_squared)``: the path constraint as written."""
    m_load, g = 50.0, 9.81
    model = oc.Model("crane", gravity=(0.0, -g, 0.0))
    trolley = model.add_body("trolley", 10.0, np.diag([0.1, 0.1, 0.1]), rotation="321")
    load = model.add_body("load", m_load, np.diag([0.5, 0.5, 0.5]), rotation="321")
    oc.joints.prismatic(model, "rail", trolley.com, axis=(1, 0, 0))
    oc.joints.revolute(model, "rope", load.point("hook", (0.0, 3.0, 0.0)), other=trolley.com)
    model.add_force("drive", trolley.com, ca.vertcat(model.add_input("F"), 0, 0))
    ocp = oc.OptimalControlProblem(model, t_final=4.0, t_final_bounds=(0.5, 20.0))
    ocp.initial({"trolley.x": 0.0, "load.psi": 0.0, "trolley.vbar_x": 0.0, "load.omega_z": 0.0})
    ocp.final({"trolley.x": 2.0, "load.psi": 0.0, "trolley.vbar_x": 0.0, "load.omega_z": 0.0})
    ocp.bound("F", -200.0, 200.0)
    ocp.subject_to(*tension_row(ca.sumsqr(ocp.joint_force("rope@load")), (1.05 * m_load * g) ** 2), "rope tension")
    ocp.minimize_final_time()
    ocp.minimize_effort(["F"], weight=1e-6)
    return ocp


def test_a_load_bound_in_newtons_squared_solves_as_fast_as_the_same_bound_scaled_by_hand():
    """|F|^2 <= (515 N)^2 written in N^2 and the same row divided by its bound by hand: one optimum, and the
    same IPOPT effort. Unscaled, the row's values (~2.6e5) made IPOPT creep at a small barrier parameter
    (230 iterations against 31, Radau 3 N = 30), until path rows were divided by their largest bound."""
    method = oc.Radau(30, degree=3)
    in_units = crane(lambda F2, b2: (F2, 0.0, b2)).solve(method)
    by_hand = crane(lambda F2, b2: (F2 / b2, 0.0, 1.0)).solve(method)
    assert in_units.success and by_hand.success
    assert in_units.t_final == pytest.approx(by_hand.t_final, rel=1e-7)
    assert in_units.iterations <= 1.5 * by_hand.iterations
    # The bound rides in the user's units: the tension reaches 1.05 mg and never exceeds it.
    loads = in_units.loads()
    tension = np.linalg.norm(np.array([loads[f"rope@load.F_{a}"] for a in "xyz"]), axis=0)
    assert tension.max() == pytest.approx(1.05 * 50.0 * 9.81, rel=1e-6)


def test_a_friction_cone_on_a_heavy_wheel_costs_ipopt_no_more_than_on_a_light_one():
    """A wheel rolling up a slope in a friction cone (examples/wheel_on_slope.py's problem, written here): at 2 kg
    and at 2,000 kg the same motion, the optimum scaled by the mass squared. The cone's rows, 0-bounded, are in
    N^2: unscaled, IPOPT took 56 iterations at 2 kg and 229 at 2,000 kg (Radau 3 N = 20); divided by the model's
    weight W and (mu W)^2, 13 and 21."""
    def wheel(m):
        model = oc.Model("wheel", gravity=(-9.81 * math.sin(0.35), 0.0, -9.81 * math.cos(0.35)))
        disk = model.add_body("disk", m, m * 0.04 * np.diag([0.25, 0.5, 0.25]), rotation="213")
        E = [ca.DM.eye(3)[:, k] for k in range(3)]
        model.add_constraint("plane.v2", ca.dot(E[1], disk.com.v), joint="plane", position=disk.com.position[1])
        model.add_constraint("plane.w1", ca.dot(E[0], disk.omega), joint="plane")
        model.add_constraint("plane.w3", ca.dot(E[2], disk.omega), joint="plane")
        contact = disk.com.v + ca.cross(disk.omega, ca.DM([0, 0, -0.2]))
        model.add_constraint("contact.t", ca.dot(E[0], contact), joint="contact")
        model.add_constraint("contact.n", ca.dot(E[2], contact), joint="contact", position=disk.com.position[2] - 0.2)
        model.add_torque("axle", disk, ca.vertcat(0, model.add_input("axle"), 0))
        ocp = oc.OptimalControlProblem(model, t_final=1.5)
        ocp.initial({"disk.x": 0.0, "disk.psi": 0.0, "disk.theta": 0.0, "disk.phi": 0.0, "disk.vbar_x": 0.0})
        ocp.final({"disk.x": 1.0, "disk.vbar_x": 0.0})
        ocp.minimize_effort()
        ocp.friction_cone("contact", 0.6)
        return ocp.solve(oc.Radau(20, degree=3))

    light, heavy = wheel(2.0), wheel(2000.0)
    assert light.success and heavy.success
    assert heavy.objective == pytest.approx(light.objective * 1000.0**2, rel=1e-7)
    assert heavy.iterations <= 2 * light.iterations


@pytest.mark.slow
def test_radaus_input_at_t0_held_in_its_bounds_costs_the_crane_only_on_a_coarse_mesh():
    """Radau has no collocation point at t0; its input there is the first interval's polynomial extrapolated and
    is held inside the input's bounds (README, "Known limitations"). The crane's trolley force starts at its
    bound, so on 20 intervals that row restricts the first interval: ours ends later than the same collocation
    in minimal coordinates (x, swing), derived from Lagrange's equations with no input at t0
    (tests/newcomer_reference.py); on 40 intervals the two are one optimum."""
    from newcomer_reference import LagrangeSystem, RigidBody, radau_solve, rot3

    q, w = ca.SX.sym("q", 2), ca.SX.sym("w", 1)
    hook = ca.vertcat(q[0], 0, 0)
    bodies = [RigidBody(10.0, 0.1 * np.eye(3), hook, ca.DM.eye(3)),
              RigidBody(50.0, 0.5 * np.eye(3), hook + rot3(q[1]) @ ca.DM([0, -3.0, 0]), rot3(q[1]))]
    gravity = np.array([0.0, -9.81, 0.0])
    system = LagrangeSystem(q, w, bodies, gravity,
                            LagrangeSystem(q, w, bodies, gravity).force_work(hook, ca.vertcat(w[0], 0, 0)))
    v = ca.jtimes(system.bodies[1].x, system.q, system.qd)
    pull = 50.0 * (ca.jtimes(v, system.q, system.qd) + ca.jtimes(v, system.qd, system.qdd) - ca.DM(gravity))
    t_final = {}
    for N in (20, 40):
        reference = radau_solve(system, N, 4.0, 1e-6 * ca.sumsqr(system.w), {i: 0.0 for i in range(4)},
                                {0: 2.0, 1: 0.0, 2: 0.0, 3: 0.0}, input_bounds=(-200.0, 200.0),
                                path=[(ca.sumsqr(pull), -np.inf, (1.05 * 50.0 * 9.81) ** 2)],
                                free_time=(0.5, 20.0), time_weight=1.0)
        ours = crane(lambda F2, b2: (F2, 0.0, b2)).solve(oc.Radau(N, degree=3))
        assert ours.success
        t_final[N] = (ours.t_final, reference["t_final"])
    assert t_final[20][0] > t_final[20][1] * (1 + 1e-3)           # restricted at t0: 2.6373 s against 2.6305 s
    assert t_final[40][0] == pytest.approx(t_final[40][1], rel=1e-7)


# -- interruption ----------------------------------------------------------------------------------
def test_sigint_stops_ipopt_and_keeps_the_last_iterate(monkeypatch):
    """A real SIGINT, sent to this process during IPOPT's third iteration."""
    from ocp_constraints.ocp.progress import IterationMonitor

    original = IterationMonitor.eval

    def eval_and_interrupt(self, arg):
        if self.iterations == 2:
            os.kill(os.getpid(), signal.SIGINT)
        return original(self, arg)

    monkeypatch.setattr(IterationMonitor, "eval", eval_and_interrupt)
    # Ctrl-C as an interactive shell delivers it (a job started in the background has SIGINT ignored)
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        with pytest.raises(oc.OCPSolveError) as info:
            cart_pole().solve(oc.Radau(20, degree=3))
        handler_after = signal.getsignal(signal.SIGINT)
    finally:
        signal.signal(signal.SIGINT, previous)
    sol = info.value.solution
    assert sol.status == "interrupted by SIGINT" and not sol.success
    assert sol.iterations == 2       # IPOPT counts from 0: stopped in the callback after iteration 2
    assert np.all(np.isfinite(sol.decision_vector))
    assert handler_after is signal.default_int_handler     # the handler is given back
