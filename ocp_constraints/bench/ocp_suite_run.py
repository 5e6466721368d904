"""``ocp-constraints bench --ocp-suite``: the user-problem suite, ours against rockit and a reference.

Per problem (:data:`PROBLEMS`):

1. ours: the problem of :mod:`.ocp_suite` / :mod:`.ocp_suite_3d`, from its user-level guess, Radau
   degree 3 on ``N`` intervals, built and solved ``runs`` times from scratch (median time: from
   an empty model to the solution, so the equations' derivation and the NLP's build count);
2. rockit: the minimal-coordinate problem of :mod:`.ocp_suite_minimal` in rockit, the same
   degree and ``N``, from the same guess (median time: from an empty ``rockit.Ocp`` to the solution);
3. ours on a fine mesh (``fine``), started from the coarse solution (mesh refinement);
4. the reference: the minimal-coordinate problem by the plain collocation of :mod:`.ocp_suite_peers`
   on its fine mesh, started from our fine solution mapped into minimal coordinates where a
   mapping is given (so it is the same local optimum: the swing-ups have several), else from the
   linear guess; its own mesh error is estimated by a second solve on half its intervals.

Agreement is ``|J_fine - J_ref| / |J_ref|``. Results: ``ocp_suite.csv`` and ``ocp_suite.md``.
"""
from __future__ import annotations

import csv
import io
import statistics
import time
from dataclasses import dataclass, field
from typing import Callable

import numpy as np

from . import ocp_suite as planar
from . import ocp_suite_3d as spatial
from . import ocp_suite_minimal as minimal
from . import ocp_suite_minimal_3d as minimal3d
from .ocp_suite_peers import collocate, solve_rockit
from .peers import available


def _angles(names: list[str], signs=None) -> Callable:
    """Minimal states ``(coordinates, their rates)`` from our solution: named coordinates times signs."""
    signs = signs or [1.0] * len(names)

    def states(sol, inputs: list[str], t: np.ndarray):
        X = np.array([s * sol.interpolate(n, t) for n, s in zip(names, signs)]
                     + [s * sol.interpolate(_rate(n), t) for n, s in zip(names, signs)])
        U = np.array([sol.interpolate(n, t) for n in inputs])
        return X, U

    return states


def _rate(name: str) -> str:
    return name.replace(".x", ".vbar_x") if name.endswith(".x") else f"{name}_dot"


@dataclass
class SuiteProblem:
    name: str
    ours: Callable
    minimal: Callable
    guess: str                               # the user-level guess, in words
    fine: tuple[int, int]                    # our fine mesh: (intervals, Radau degree)
    reference: tuple[int, int]               # the reference's mesh
    states: Callable | None = None           # our solution -> minimal states and controls
    inputs: list[str] = field(default_factory=list)   # our inputs in the minimal control order (same signs)


WALKER_LINKS = [f"{n}.psi" for n in spatial.LINKS]
PROBLEMS = [
    SuiteProblem("acrobot", planar.acrobot, minimal.acrobot, "none", (40, 7), (80, 7),
                 _angles(["upper.psi", "lower.psi"]), ["elbow_motor"]),
    SuiteProblem("cart_double_pendulum", planar.cart_double_pendulum, minimal.cart_double_pendulum, "none", (40, 7),
                 (80, 7), _angles(["cart.x", "rod1.psi", "rod2.psi"]), ["push"]),
    SuiteProblem("four_bar", planar.four_bar, minimal.four_bar, "coupler and rocker angles (loop closure)", (80, 7),
                 (160, 7), _angles(["crank.psi"]), ["motor"]),
    SuiteProblem("rolling_disk", spatial.rolling_disk, minimal3d.rolling_disk, "none", (20, 7), (40, 7)),
    SuiteProblem("quadrotor_load", spatial.quadrotor_load, minimal3d.quadrotor_load, "none", (20, 7), (40, 7)),
    SuiteProblem("walker", spatial.walker, minimal3d.walker, "none", (20, 7), (80, 7),
                 _angles(WALKER_LINKS, [-1.0] * 5), ["ankle", "hip1", "hip2", "knee1", "knee2"]),
]


def _ours(sp: SuiteProblem, N: int) -> tuple[dict, object]:
    import ocp_constraints as oc

    started = time.perf_counter()
    problem = sp.ours()
    try:
        sol = problem.solve(oc.Radau(N, degree=3))
    except oc.OCPSolveError as exc:
        sol = exc.solution
    total = time.perf_counter() - started
    return {"success": sol.success, "status": sol.status, "iterations": sol.iterations, "objective": sol.objective,
            "solve_s": total, "ipopt_s": sol.wall_time["solve"]}, (problem, sol)


def _median_row(rows: list[dict]) -> dict:
    out = dict(rows[-1])
    for k in ("solve_s", "ipopt_s"):
        out[k] = statistics.median(r[k] for r in rows)
    out["success"] = all(r["success"] for r in rows)
    return out


def run_problem(sp: SuiteProblem, N: int, runs: int, log=print) -> dict:
    """One row of the suite's table (see the module docstring)."""
    import ocp_constraints as oc

    mp = sp.minimal()
    ours, peer, kept = [], [], None
    have_rockit = available("rockit")
    for _ in range(runs):                 # alternate, so both see the same machine load
        row, kept = _ours(sp, N)
        ours.append(row)
        if have_rockit:
            peer.append(solve_rockit(mp, N, 3))
    ours_row = _median_row(ours)
    log(f"  {sp.name}: ours Radau3 N={N}: {ours_row['status']}, {ours_row['iterations']} iterations, "
        f"J = {ours_row['objective']:.10g}, {ours_row['solve_s']:.2f} s")
    row = {"problem": sp.name, "guess": sp.guess, "N": N, **{f"ours_{k}": v for k, v in ours_row.items()}}
    if peer:
        rk = _median_row(peer)
        row.update({f"rockit_{k}": v for k, v in rk.items()})
        log(f"  {sp.name}: rockit N={N}: {rk['status']}, {rk['iterations']} iterations, J = {rk['objective']:.10g}, "
            f"{rk['solve_s']:.2f} s")
    problem, coarse = kept
    Nf, df = sp.fine
    started = time.perf_counter()
    try:
        fine = problem.solve(oc.Radau(Nf, degree=df), warm_start=coarse)
    except oc.OCPSolveError as exc:
        fine = exc.solution
    row.update(fine_setting=f"Radau{df} N={Nf}", fine_success=fine.success, fine_iterations=fine.iterations,
               fine_objective=fine.objective, fine_s=time.perf_counter() - started)
    Nr, dr = sp.reference
    start = None if sp.states is None else (lambda t: sp.states(fine, sp.inputs, t))
    ref = collocate(mp, Nr, dr, start=start)
    half = collocate(mp, Nr // 2, dr, start=start)
    from_guess = collocate(mp, Nr, dr) if start is not None else ref
    J = ref["objective"]
    row.update(reference_setting=ref["setting"] + (", from our fine solution" if start else ", from the linear guess"),
               reference_success=ref["success"], reference_objective=J,
               reference_mesh_error=abs(J - half["objective"]) / abs(J),
               reference_from_guess_objective=from_guess["objective"], reference_from_guess_success=from_guess["success"],
               agreement=abs(fine.objective - J) / abs(J))
    log(f"  {sp.name}: ours {row['fine_setting']}: J = {fine.objective:.10g} ({fine.iterations} iterations, "
        f"{row['fine_s']:.1f} s); reference {ref['setting']}: J = {J:.10g} (mesh error {row['reference_mesh_error']:.1e}); "
        f"agreement {row['agreement']:.1e}; from the linear guess J = {from_guess['objective']:.10g}")
    return row


COLUMNS = ["problem", "guess", "N", "ours_success", "ours_status", "ours_iterations", "ours_solve_s", "ours_ipopt_s",
           "ours_objective", "fine_setting", "fine_success", "fine_iterations", "fine_objective", "fine_s",
           "reference_setting", "reference_success", "reference_objective", "reference_mesh_error", "agreement",
           "reference_from_guess_objective", "reference_from_guess_success", "rockit_success", "rockit_status",
           "rockit_iterations", "rockit_solve_s", "rockit_ipopt_s", "rockit_objective"]


def csv_text(rows: list[dict]) -> str:
    buf = io.StringIO()
    w = csv.DictWriter(buf, COLUMNS, extrasaction="ignore")
    w.writeheader()
    for r in rows:
        w.writerow({k: (f"{v:.12g}" if isinstance(v, float) else v) for k, v in r.items()})
    return buf.getvalue()


def markdown(rows: list[dict], runs: int) -> str:
    """The README table: one line per problem."""
    head = ("| problem | guess | ours: success, iterations | ours: time (s) | ours: J (N) | fine J, agreement with the "
            "reference | reference J (its mesh error) | rockit: success, iterations | rockit: time (s) | rockit: J (N) "
            "| time ours/rockit |")
    lines = [head, "|" + "---|" * 11]
    for r in rows:
        rk = "rockit_objective" in r
        ratio = f"{r['ours_solve_s'] / r['rockit_solve_s']:.2f}" if rk else "rockit not installed"
        lines.append(
            f"| {r['problem']} | {r['guess']} | {'yes' if r['ours_success'] else 'no (' + r['ours_status'] + ')'}, "
            f"{r['ours_iterations']} | {r['ours_solve_s']:.2f} | {r['ours_objective']:.6f} | "
            f"{r['fine_objective']:.9g} ({r['fine_setting']}), {r['agreement']:.1e} | "
            f"{r['reference_objective']:.9g} ({r['reference_mesh_error']:.0e}) | "
            + (f"{'yes' if r['rockit_success'] else 'no (' + r['rockit_status'] + ')'}, {r['rockit_iterations']} | "
               f"{r['rockit_solve_s']:.2f} | {r['rockit_objective']:.6f} | {ratio} |" if rk else "| | | |"))
    return "\n".join(lines) + "\n"


SUITE_START = "<!-- ocp suite: written by `ocp-constraints bench --ocp-suite --readme README.md` -->"
SUITE_END = "<!-- end of ocp suite -->"


def run_suite(out, runs: int = 3, N: int = 20, only: list[str] | None = None, readme=None, log=print) -> list[dict]:
    """Run the suite (or the problems ``only``), write ``ocp_suite.csv`` and ``ocp_suite.md`` into ``out``
    and, with ``readme``, the table between the README's suite markers."""
    from pathlib import Path

    from ..errors import SceneError
    from ..output.files import prepare_output_folder, write_atomic
    from .work_precision import machine

    names = [sp.name for sp in PROBLEMS]
    unknown = sorted(set(only or []) - set(names))
    if unknown:
        raise SceneError(f"bench --ocp-suite: unknown problem(s) {unknown}; suite problems: {', '.join(names)}")
    if readme is not None:
        splice(Path(readme), None)                     # fail now, not after the run
    folder = prepare_output_folder(out)
    started = time.perf_counter()
    if not available("rockit"):
        log("  rockit is not installed (pip install rockit-meco, the bench extra): its columns stay empty")
    rows = []
    for sp in PROBLEMS:
        if only and sp.name not in only:
            continue
        log(f"== {sp.name}")
        rows.append(run_problem(sp, N, runs, log))
    m = machine()
    minutes = (time.perf_counter() - started) / 60
    text = (f"Regenerated by `ocp-constraints bench --ocp-suite{' --readme ' + str(readme) if readme else ''}` "
            f"({minutes:.1f} min on this machine: {m['cpus']} cores, Python {m['python']}, CasADi {m['casadi']}, "
            f"{m['date']}). Times are medians of {runs} runs, each from an empty model to the solution; ours and "
            f"rockit both Radau collocation of degree 3 on N = {N} intervals.\n\n" + markdown(rows, runs))
    write_atomic(folder / "ocp_suite.csv", csv_text(rows).encode())
    write_atomic(folder / "ocp_suite.md", text.encode())
    if readme is not None:
        splice(Path(readme), text)
        log(f"  {readme}: the suite's table replaced")
    log(f"ocp suite finished in {minutes:.1f} min; results in {folder}")
    return rows


def splice(readme, text: str | None) -> None:
    """Replace the text between the suite markers of ``readme``; ``text=None`` only checks them."""
    from ..errors import SceneError
    from ..output.files import write_atomic

    try:
        current = readme.read_text()
    except OSError as exc:
        raise SceneError(f"bench --ocp-suite --readme: cannot read {readme}: {exc.strerror}") from exc
    if current.count(SUITE_START) != 1 or current.count(SUITE_END) != 1 or current.index(SUITE_START) > current.index(SUITE_END):
        raise SceneError(f"bench --ocp-suite --readme: {readme} needs one line '{SUITE_START}' and, after it, one line "
                         f"'{SUITE_END}'; the table goes between them")
    if text is None:
        return
    head, rest = current.split(SUITE_START)
    tail = rest.split(SUITE_END, 1)[1]
    write_atomic(readme, f"{head}{SUITE_START}\n{text.rstrip()}\n{SUITE_END}{tail}".encode())
