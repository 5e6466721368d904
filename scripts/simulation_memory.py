"""Memory a simulation needs per sample: the estimate of ``dynamics/preflight.py`` against ``tracemalloc``.

    python scripts/simulation_memory.py [SCENE ...]      (default: pendulum ball_socket whirling)

For each scene, ``run_simulation`` (samples kept, results files written, no plots) runs for two
lengths at dt = 1 ms under ``tracemalloc``; the growth of the peak between them, per sample, is
the measured cost (the fixed cost of building the model cancels). It is printed beside
``samples_memory(eqs, 1)``, the estimate ``simulate`` uses to refuse runs larger than the machine.
"""
from __future__ import annotations

import gc
import sys
import tempfile
import tracemalloc

import ocp_constraints as oc
from ocp_constraints.dynamics.preflight import samples_memory
from ocp_constraints.dynamics.simulate import SimulationOptions
from ocp_constraints.scenes.tasks import run_simulation


def measured_bytes_per_sample(name: str, lengths=(1.0, 4.0), dt: float = 0.001) -> float:
    peaks = {}
    for t_final in lengths:
        scene = oc.build_scene(name)
        gc.collect()
        tracemalloc.start()
        with tempfile.TemporaryDirectory() as d:
            traj, _ = run_simulation(scene, name, t_final, d, SimulationOptions(dt=dt), plots=False)
        peaks[len(traj)] = tracemalloc.get_traced_memory()[1]
        tracemalloc.stop()
        del traj
    (n1, p1), (n2, p2) = sorted(peaks.items())
    return (p2 - p1) / (n2 - n1)


def main(names: list[str]) -> None:
    print("| scene | measured (tracemalloc), bytes a sample | estimate (samples_memory) | estimate / measured |")
    print("|---|---|---|---|")
    for name in names or ["pendulum", "ball_socket", "whirling"]:
        measured = measured_bytes_per_sample(name)
        estimate = samples_memory(oc.SystemEquations(oc.build_scene(name).model), 1)
        print(f"| {name} | {measured:.0f} | {estimate} | {estimate / measured:.2f} |")


if __name__ == "__main__":
    main(sys.argv[1:])
