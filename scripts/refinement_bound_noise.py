"""How tightly IPOPT holds an input at its bound next to a junction, and what ``compl_inf_tol`` buys (issue 19).

    python scripts/refinement_bound_noise.py [--out results/bench/refinement_bound_noise.md]

IPOPT is an interior-point method: at its solution an active bound ``F <= U`` is held at a distance
``mu / z``, ``z`` the bound's multiplier in the NLP. Transcribed, ``z`` at a collocation point is its quadrature
weight times the continuous multiplier, which falls to zero at a junction (where the input leaves its bound):
on short intervals next to a junction the input "at" its bound is off it, and off the exact solution, by far
more than IPOPT's tolerance suggests. This script measures it on the push clipped at its upper bound
(``clipped_upper`` of scripts/refinement_holdout_problems.py: F = min(U, a - b t), closed form by root-finding)
on one fixed mesh: Radau 5 on ten uniform intervals plus six short ones (2e-4 to 3e-3 of the horizon) around
the junction, the kind of mesh a refinement builds there. Per ``compl_inf_tol`` (IPOPT's default 1e-4 leaves
its scaled ``tol``, 1e-10 here, in charge): IPOPT iterations, the largest distance of F from U on the active
arc, and the largest error of F against the closed form (over the points, t > 0). A measurement, not a test.
"""
from __future__ import annotations

import argparse
import importlib.util
import sys
import time
from pathlib import Path

import numpy as np

import ocp_constraints as oc

_SPEC = importlib.util.spec_from_file_location("refinement_holdout_problems",
                                               Path(__file__).with_name("refinement_holdout_problems.py"))
problems = importlib.util.module_from_spec(_SPEC)
sys.modules.setdefault("refinement_holdout_problems", problems)
_SPEC.loader.exec_module(problems)

SETTINGS = (None, 1e-12, 1e-13, 1e-14)


def mesh_around_junction() -> oc.Radau:
    ref = problems.clipped_upper_reference()
    f1 = ref.switches[0] / ref.t_final
    mesh = sorted({0.0, 1.0, *np.linspace(0, 1, 11)[1:-1], *(f1 + np.array([-3e-3, -1e-3, -3e-4, 2e-4, 7e-4, 2e-3]))})
    return oc.Radau(mesh=tuple(mesh), degrees=tuple([5] * (len(mesh) - 1)))


def measure(compl: float | None) -> dict:
    ref = problems.clipped_upper_reference()
    options = {} if compl is None else {"ipopt.compl_inf_tol": compl}
    cpu = time.process_time()
    sol = problems.clipped_upper_problem().solve(mesh_around_junction(), options, progress=False)
    cpu = time.process_time() - cpu
    t, F = sol.t, np.asarray(sol.sample("F"), float)
    exact = ref.values(t)["F"]
    active = (t > 0) & (t < ref.switches[0])
    return {"compl": compl, "iterations": sol.iterations, "cpu": cpu,
            "off_bound": float(np.abs(problems.CLU_U - F[active]).max()),
            "error": float(np.abs(F - exact)[t > 0].max()), "objective": sol.objective}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=None)
    args = parser.parse_args()
    rows = [measure(c) for c in SETTINGS]
    lines = ["# IPOPT's hold on an active input bound next to a junction (issue 19)", "",
             f"`python scripts/refinement_bound_noise.py` ({time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}); "
             f"the push clipped at F <= {problems.CLU_U} N, Radau 5 on {mesh_around_junction().intervals} intervals, "
             "six of them 2e-4 to 3e-3 of the horizon around the junction. F is in N.", "",
             "| `compl_inf_tol` | IPOPT iterations | F's largest distance from U on the active arc | "
             "F's largest error against the closed form | CPU s |", "|---|---|---|---|---|"]
    for r in rows:
        name = "IPOPT's default (its scaled tol 1e-10 decides)" if r["compl"] is None else f"{r['compl']:g}"
        lines.append(f"| {name} | {r['iterations']} | {r['off_bound']:.1e} | {r['error']:.1e} | {r['cpu']:.2f} |")
    text = "\n".join(lines) + "\n"
    print(text)
    if args.out:
        args.out.write_text(text)


if __name__ == "__main__":
    main()
