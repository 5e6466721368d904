"""Unit quaternions give the same motion and loads as Euler angles (ball_socket scene)."""
from __future__ import annotations

import numpy as np

from ocp_constraints import SystemEquations, build_scene
from ocp_constraints.mechanics.rotations import EulerSequence, quaternion_from_rotation
from ocp_constraints.scenes.tasks import simulate_scene


def _run(quaternion: float, t_final: float):
    traj = simulate_scene(build_scene("ball_socket", {"quaternion": quaternion}), t_final)
    return traj.eqs, traj


def test_quaternion_and_313_chains_give_the_same_loads_over_one_second():
    _, euler = _run(0.0, 1.0)
    _, quat = _run(1.0, 1.0)
    scale = np.abs(euler.lam).max()
    assert np.abs(euler.lam - quat.lam).max() <= 1e-9 * scale
    le, lq = euler.loads(), quat.loads()
    for key in ("socket_C@body2.F_x", "socket_O.F_z", "socket_O.power"):
        assert np.abs(le[key] - lq[key]).max() <= 1e-9 * scale


def test_quaternion_forward_dynamics_matches_euler_pointwise():
    eqs_e, euler = _run(0.0, 0.5)
    eqs_q = SystemEquations(build_scene("ball_socket", {"quaternion": 1.0}).model)
    seq = EulerSequence("313")
    for q, u, t, lam in list(zip(euler.q, euler.u, euler.t, euler.lam))[::10]:
        qq = []
        for body in range(2):
            xb, ang = q[6 * body : 6 * body + 3], q[6 * body + 3 : 6 * body + 6]
            qq += [*xb, *quaternion_from_rotation(np.asarray(seq.rotation(ang)))]
        udot_q, lam_q = eqs_q.forward_dynamics(np.array(qq), u, t, [], [])
        udot_e, _ = eqs_e.forward_dynamics(q, u, t, [], [])
        assert np.allclose(np.asarray(lam_q).ravel(), lam, rtol=0, atol=1e-11)
        assert np.allclose(np.asarray(udot_q).ravel(), np.asarray(udot_e).ravel(), rtol=0, atol=1e-11)
