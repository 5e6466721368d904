"""Where the CPU of ``problem.solve(tolerance=...)`` goes, phase by phase, beside one fixed-mesh solve (issue 19).

    python scripts/mesh_refinement_phases.py [--runs 5] [--tolerances 1e-4 1e-6 1e-8] [--fixed 5x20 7x20 8x20]

Swing-up (pendulum swing_up, the library's default coordinates). Each phase's CPU
(``time.process_time``) is summed over the whole call by wrapping the library's functions (no
profiler: its overhead per call would inflate the many small CasADi calls); medians of ``runs``
after one untimed run (imports, first calls). Phases: the problem's build (``build_task``), the
pre-solve check, the transcriptions' builds (of which: element functions, their assembly into
IPOPT's derivatives (BlockNLP), ``nlpsol``), the guesses (``initial_guess``/``guess_from``),
IPOPT itself (``Transcription.solve`` less what it calls of the above and ``completed``/``from_vector``),
the completion of solutions, the estimates (``estimate_error``, ``legendre_decay``). The fixed rows
(``DxN``: Radau degree D on N intervals) are what the bench compares the refined solve with.
"""
from __future__ import annotations

import argparse
import statistics
import time
from contextlib import contextmanager

from ocp_constraints.ocp import joint_transcription, mesh_refinement, nlp_assembly, transcription, transcription_elements
from ocp_constraints.ocp import diagnostics
from ocp_constraints.ocp.schemes import Radau
from ocp_constraints.scenes import registry

PHASES = [
    ("problem", registry, "build_task"),
    ("check", diagnostics, "check_problem"),
    ("build", transcription.Transcription, "__init__"),
    ("elements", transcription_elements.ElementKinds, "_elements"),
    ("block", nlp_assembly.BlockNLP, "__init__"),
    ("guess", joint_transcription.JointTranscription, "guess_from"),
    ("guess", joint_transcription.JointTranscription, "initial_guess"),
    ("guess", transcription.Transcription, "guess_from"),
    ("guess", transcription.Transcription, "initial_guess"),
    ("completed", joint_transcription.JointTranscription, "completed"),
    ("solve", transcription.Transcription, "solve"),
    ("estimate", mesh_refinement, "estimate_error"),
    ("estimate", mesh_refinement, "legendre_decay"),
]


@contextmanager
def timed_phases(spent: dict):
    """Wrap each phase's function so that its CPU adds to ``spent[phase]`` (outermost call only)."""
    originals, depth = [], {}

    def wrap(phase, owner, name):
        original = owner.__dict__[name]

        def timed(*args, **kwargs):
            if depth.get((phase, name)):
                return original(*args, **kwargs)
            depth[(phase, name)] = 1
            cpu = time.process_time()
            try:
                return original(*args, **kwargs)
            finally:
                spent[phase] = spent.get(phase, 0.0) + time.process_time() - cpu
                depth[(phase, name)] = 0

        setattr(owner, name, timed)
        originals.append((owner, name, original))

    for phase, owner, name in PHASES:
        if name in owner.__dict__:
            wrap(phase, owner, name)
    # nlpsol and IPOPT's own call happen inside Transcription.solve: time nlpsol there.
    import casadi as ca

    original_nlpsol = transcription.ca.nlpsol

    def nlpsol(*args, **kwargs):
        cpu = time.process_time()
        try:
            return original_nlpsol(*args, **kwargs)
        finally:
            spent["nlpsol"] = spent.get("nlpsol", 0.0) + time.process_time() - cpu

    transcription.ca.nlpsol = nlpsol
    try:
        yield
    finally:
        transcription.ca.nlpsol = original_nlpsol
        assert ca.nlpsol is original_nlpsol
        for owner, name, original in originals:
            setattr(owner, name, original)


def run_once(solve) -> dict:
    spent: dict = {}
    with timed_phases(spent):
        cpu = time.process_time()
        sol = solve()
        spent["total"] = time.process_time() - cpu
    # IPOPT and the rest of Transcription.solve: its CPU less the guesses, nlpsol and completion inside it.
    spent["ipopt+"] = spent.get("solve", 0.0) - spent.get("guess", 0.0) - spent.get("nlpsol", 0.0) - spent.get("completed", 0.0)
    mr = getattr(sol, "mesh_refinement", None)
    spent["solves"] = sum(h["solves"] for h in mr["history"]) if mr else 1
    return spent


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=5)
    ap.add_argument("--tolerances", type=float, nargs="+", default=[1e-4, 1e-6, 1e-8])
    ap.add_argument("--fixed", nargs="+", default=["5x20", "7x10", "8x10", "7x20", "8x20"])
    args = ap.parse_args(argv)
    cases = [(f"tolerance {tol:g}", lambda tol=tol: registry.build_task("pendulum", "swing_up")[1].solve(tolerance=tol))
             for tol in args.tolerances]
    for spec in args.fixed:
        d, N = (int(v) for v in spec.split("x"))
        cases.append((f"fixed radau{d} N={N}", lambda d=d, N=N: registry.build_task("pendulum", "swing_up")[1].solve(Radau(N, degree=d))))
    keys = ["total", "problem", "check", "build", "elements", "block", "nlpsol", "guess", "ipopt+", "completed", "estimate"]
    print(f"CPU ms, medians of {args.runs} (swing-up, default coordinates)")
    print(f"{'case':24s} {'solves':>6s} " + " ".join(f"{k:>9s}" for k in keys))
    for label, solve in cases:
        run_once(solve)
        runs = [run_once(solve) for _ in range(args.runs)]
        med = {k: statistics.median(r.get(k, 0.0) for r in runs) for k in keys + ["solves"]}
        print(f"{label:24s} {med['solves']:6.0f} " + " ".join(f"{1e3 * med[k]:9.1f}" for k in keys))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
