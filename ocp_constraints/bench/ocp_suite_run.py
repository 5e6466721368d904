"""``ocp-constraints bench --ocp-suite``: the user-problem suite, ours against rockit and a reference.

Per problem (:data:`PROBLEMS`):

1. ours: the problem of :mod:`.ocp_suite` / :mod:`.ocp_suite_3d`, from its user-level guess, Radau
   degree 3 on ``N`` intervals, built and solved ``runs`` times from scratch (median time: from
   an empty model to the solution, so the equations' derivation and the NLP's build count), once
   in maximal coordinates (the default) and once with ``coordinates="joint"``;
2. rockit: the minimal-coordinate problem of :mod:`.ocp_suite_minimal` in rockit, the same
   degree and ``N``, from the same guess (median time: from an empty ``rockit.Ocp`` to the solution);
   the three alternate run by run, so they see the same machine load;
3. ours on a fine mesh (``fine``), started from the coarse solution (mesh refinement);
4. the reference: the minimal-coordinate problem by the plain collocation of :mod:`.ocp_suite_peers`
   on its fine mesh, started from our fine solution mapped into minimal coordinates where a
   mapping is given (so it is the same local optimum: the swing-ups have several), else from the
   linear guess; its own mesh error is estimated by a second solve on half its intervals.

Agreement is ``|J_fine - J_ref| / |J_ref|``; on our fine mesh, the same with the reference's solve on
half its intervals (our fine mesh: the same discrete problem in other coordinates). Times are wall (``*_s``) and CPU (``*_cpu_s``) seconds
of this process. Results: ``ocp_suite.csv`` and ``ocp_suite.md``.
"""
from __future__ import annotations

import csv
import io
import statistics
import time
from dataclasses import dataclass, field
from pathlib import Path
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


def _disk_states(sol, inputs: list[str], t: np.ndarray):
    """The rolling disk's minimal state: (x, y, psi, theta, phi) and the angle rates (its speeds)."""
    q = [f"disk.{c}" for c in ("x", "y", "psi", "theta", "phi")]
    X = np.array([sol.interpolate(n, t) for n in q] + [sol.interpolate(f"{n}_dot", t) for n in q[2:]])
    return X, np.array([sol.interpolate(n, t) for n in inputs])


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
    SuiteProblem("four_bar", planar.four_bar, minimal.four_bar, "rocker angle upright (one coordinate)", (40, 7),
                 (80, 7), _angles(["crank.psi"]), ["motor"]),
    SuiteProblem("rolling_disk", spatial.rolling_disk, minimal3d.rolling_disk, "none", (40, 7), (80, 7),
                 _disk_states, ["tau_x", "tau_y", "tau_z"]),
    SuiteProblem("quadrotor_load", spatial.quadrotor_load, minimal3d.quadrotor_load, "none", (40, 7), (80, 7)),
    SuiteProblem("walker", spatial.walker, minimal3d.walker, "none", (40, 7), (80, 7),
                 _angles(WALKER_LINKS, [-1.0] * 5), ["ankle", "hip1", "hip2", "knee1", "knee2"]),
]


def _ours(sp: SuiteProblem, N: int, coordinates: str = "maximal") -> tuple[dict, object]:
    """Build ``sp``'s problem from an empty model and solve it (Radau 3, ``N`` intervals), timed."""
    import ocp_constraints as oc

    started, cpu = time.perf_counter(), time.process_time()
    problem = sol = None
    try:
        problem = sp.ours(coordinates=coordinates)
        sol = problem.solve(oc.Radau(N, degree=3), progress=False)
    except oc.OCPSolveError as exc:
        sol = exc.solution
    except oc.OcpConstraintsError as exc:        # e.g. a model the joint coordinates do not cover
        return {"success": False, "status": f"{type(exc).__name__}: {exc}"[:200], "iterations": 0,
                "objective": float("nan"), "solve_s": time.perf_counter() - started,
                "cpu_s": time.process_time() - cpu, "ipopt_s": float("nan")}, (problem, None)
    _stop_if_interrupted(sol)
    return {"success": bool(sol.success), "status": sol.status, "iterations": sol.iterations,
            "objective": float(sol.objective), "solve_s": time.perf_counter() - started,
            "cpu_s": time.process_time() - cpu, "ipopt_s": sol.wall_time["solve"]}, (problem, sol)


def _stop_if_interrupted(sol) -> None:
    """Ctrl-C or SIGTERM stops the solve with its last iterate; the suite stops there too."""
    if str(sol.status).startswith("interrupted"):
        raise KeyboardInterrupt(f"bench --ocp-suite: {sol.status}")


def _rockit(mp, N: int) -> dict:
    cpu = time.process_time()
    row = solve_rockit(mp, N, 3)
    row["cpu_s"] = time.process_time() - cpu
    return row


def _median_row(rows: list[dict]) -> dict:
    out = dict(rows[-1])
    for k in ("solve_s", "cpu_s", "ipopt_s"):
        out[k] = statistics.median(r[k] for r in rows)
    out["success"] = all(r["success"] for r in rows)
    return out


def _say(log, what: str, r: dict, N: int) -> None:
    log(f"  {what} N={N}: {r['status']}, {r['iterations']} iterations, J = {r['objective']:.10g}, "
        f"{r['solve_s']:.2f} s wall, {r['cpu_s']:.2f} s CPU")


def run_problem(sp: SuiteProblem, N: int, runs: int, log=print, fine_mesh: tuple[int, int] | None = None,
                coordinates: tuple[str, ...] = ("maximal", "joint")) -> dict:
    """One row of the suite's table (see the module docstring). ``fine_mesh``: ``(intervals, degree)``
    of our fine solve instead of the problem's own, the reference then on twice the intervals;
    ``coordinates``: with ``"joint"``, our problem is also solved in joint coordinates."""
    import ocp_constraints as oc

    mp = sp.minimal()
    ours, joint, peer, kept, kept_joint = [], [], [], None, None
    have_rockit = available("rockit")
    for _ in range(runs):                 # alternate, so all three see the same machine load
        row, kept = _ours(sp, N)
        ours.append(row)
        # A failed solve is not repeated: its time would be IPOPT's iteration limit, not a median.
        if "joint" in coordinates and (not joint or joint[-1]["success"]):
            r, kept_joint = _ours(sp, N, "joint")
            joint.append(r)
        if have_rockit:
            peer.append(_rockit(mp, N))
    row = {"problem": sp.name, "guess": sp.guess, "N": N}
    for prefix, rows in (("ours", ours), ("joint", joint), ("rockit", peer)):
        if rows:
            r = _median_row(rows)
            _say(log, f"{sp.name}: {prefix}", r, N)
            row.update({f"{prefix}_{k}": v for k, v in r.items() if k != "setting"})
    # The fine solve in joint coordinates where those solved the coarse problem (several times
    # faster), else in maximal coordinates; from the coarse solution of the same kind.
    via_joint = bool(joint) and joint[-1]["success"]
    Nf, df = fine_mesh or sp.fine
    started, cpu = time.perf_counter(), time.process_time()
    for problem, coarse in ([kept_joint] if via_joint else []) + [kept]:
        # The joint form gets 300 iterations (a warm-started fine solve needs under 100): the rolling disk's
        # ran for over 10 min of CPU at Radau 7, N = 40, where the maximal form needs 40 iterations.
        limit = {"ipopt.max_iter": 300} if via_joint else None
        try:
            fine = (problem or sp.ours()).solve(oc.Radau(Nf, degree=df), limit, warm_start=coarse, progress=False)
        except oc.OCPSolveError as exc:
            fine = exc.solution
        _stop_if_interrupted(fine)
        if fine.success:
            break
        if via_joint:           # the joint form failed on the fine mesh: maximal coordinates, from their coarse solution
            log(f"  {sp.name}: fine mesh in joint coordinates: {fine.status} after {fine.iterations} iterations; "
                f"solved again in maximal coordinates")
            via_joint = False
    row.update(fine_setting=f"Radau{df} N={Nf}{', joint coordinates' if via_joint else ''}", fine_success=fine.success,
               fine_iterations=fine.iterations, fine_objective=fine.objective, fine_s=time.perf_counter() - started,
               fine_cpu_s=time.process_time() - cpu)
    Nr, dr = (2 * fine_mesh[0], fine_mesh[1]) if fine_mesh else sp.reference
    start = None if sp.states is None else (lambda t: sp.states(fine, sp.inputs, t))
    ref = collocate(mp, Nr, dr, start=start)
    half = collocate(mp, Nr // 2, dr, start=start)
    from_guess = collocate(mp, Nr, dr) if start is not None else ref
    J = ref["objective"]
    row.update(reference_setting=ref["setting"] + (", from our fine solution" if start else ", from the linear guess"),
               reference_success=ref["success"], reference_objective=J,
               reference_mesh_error=abs(J - half["objective"]) / abs(J), reference_half_objective=half["objective"],
               agreement_equal_mesh=abs(fine.objective - half["objective"]) / abs(half["objective"]),
               reference_from_guess_objective=from_guess["objective"], reference_from_guess_success=from_guess["success"],
               agreement=abs(fine.objective - J) / abs(J))
    log(f"  {sp.name}: ours {row['fine_setting']}: J = {fine.objective:.10g} ({fine.iterations} iterations, "
        f"{row['fine_s']:.1f} s); reference {ref['setting']}: J = {J:.10g} (mesh error {row['reference_mesh_error']:.1e}); "
        f"agreement {row['agreement']:.1e} (on our mesh {row['agreement_equal_mesh']:.1e}); from the linear guess J = {from_guess['objective']:.10g}")
    return row


RUN_FIELDS = ["success", "status", "iterations", "objective", "solve_s", "cpu_s", "ipopt_s"]
COLUMNS = (["problem", "guess", "N"] + [f"{w}_{k}" for w in ("ours", "joint", "rockit") for k in RUN_FIELDS]
           + ["fine_setting", "fine_success", "fine_iterations", "fine_objective", "fine_s", "fine_cpu_s", "reference_setting",
              "reference_success", "reference_objective", "reference_mesh_error", "agreement", "reference_half_objective",
              "agreement_equal_mesh",
              "reference_from_guess_objective", "reference_from_guess_success"])


def csv_text(rows: list[dict]) -> str:
    buf = io.StringIO()
    w = csv.DictWriter(buf, COLUMNS, extrasaction="ignore")
    w.writeheader()
    for r in rows:
        w.writerow({k: (f"{v:.12g}" if isinstance(v, float) else v) for k, v in r.items()})
    return buf.getvalue()


def _cell(r: dict, who: str) -> str:
    """``yes/no, iterations | wall s (CPU s) | J`` of one solver's runs."""
    if f"{who}_success" not in r:
        return "not run | | "
    ok = "yes" if r[f"{who}_success"] else f"no ({r[f'{who}_status']})"
    return (f"{ok}, {r[f'{who}_iterations']} | {r[f'{who}_solve_s']:.2f} ({r[f'{who}_cpu_s']:.2f}) | "
            f"{r[f'{who}_objective']:.6g}")


def _ratio(r: dict, who: str, key: str) -> str:
    if f"rockit_{key}" not in r or not r.get(f"{who}_success"):
        return "-"
    return f"{r[f'{who}_{key}'] / r[f'rockit_{key}']:.2f}"


def markdown(rows: list[dict], runs: int) -> str:
    """The README table: one line per problem."""
    head = ("| problem | guess | maximal: success, iterations | maximal: time s (CPU s) | maximal: J | joint coordinates "
            "(the default, coordinates='auto'): success, iterations | joint: time s (CPU s) | joint: J | rockit: success, "
            "iterations | rockit: time s (CPU s) | rockit: J | time / rockit's, maximal (CPU) | joint (CPU) | ours, fine mesh: J | reference J (its mesh error) "
            "| agreement | agreement on our fine mesh |")
    lines = [head, "|" + "---|" * 17]
    for r in rows:
        lines.append(
            f"| {r['problem']} | {r['guess']} | {_cell(r, 'ours')} | {_cell(r, 'joint')} | {_cell(r, 'rockit')} | "
            f"{_ratio(r, 'ours', 'solve_s')} ({_ratio(r, 'ours', 'cpu_s')}) | "
            f"{_ratio(r, 'joint', 'solve_s')} ({_ratio(r, 'joint', 'cpu_s')}) | "
            f"{r['fine_objective']:.10g} ({r['fine_setting']}{'' if r['fine_success'] else ', failed'}) | "
            f"{r['reference_objective']:.10g} ({r['reference_mesh_error']:.0e}) | {r['agreement']:.1e} | "
            f"{r['agreement_equal_mesh']:.1e} |")
    return "\n".join(lines) + "\n"


SUITE_START = "<!-- ocp suite: written by `ocp-constraints bench --ocp-suite --readme README.md` -->"
SUITE_END = "<!-- end of ocp suite -->"


def run_suite(out, runs: int = 3, N: int = 20, only: list[str] | None = None, readme=None, log=print,
              fine_mesh: tuple[int, int] | None = None, coordinates: tuple[str, ...] = ("maximal", "joint")) -> list[dict]:
    """Run the suite (or the problems ``only``), write ``ocp_suite.csv`` and ``ocp_suite.md`` into ``out``
    and, with ``readme``, the table between the README's suite markers. ``N``: intervals of the timed
    solves; ``fine_mesh``, ``coordinates``: see :func:`run_problem`."""
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
    new: dict[str, dict] = {}

    def write() -> list[dict]:
        """The table so far (after every problem, so an interrupted run keeps what it has)."""
        earlier = _earlier_rows(folder, set(new))          # read now: another run may have written it meanwhile
        rows = [new.get(sp.name, earlier.get(sp.name)) for sp in PROBLEMS if sp.name in new or sp.name in earlier]
        m = machine()
        minutes = (time.perf_counter() - started) / 60
        text = (f"Regenerated by `ocp-constraints bench --ocp-suite{' --readme ' + str(readme) if readme else ''}` "
                f"({minutes:.1f} min on this machine: {m['cpus']} cores, Python {m['python']}, CasADi {m['casadi']}, "
                f"{m['date']}). Times are medians of {runs} runs, each from an empty model to the solution, wall seconds "
                f"and in brackets CPU seconds; ours (maximal coordinates, and joint coordinates) and rockit (minimal "
                f"coordinates) all Radau collocation of degree 3 on N = {N} intervals from the same guess. J: the "
                f"objective. Agreement: |J_fine - J_ref| / |J_ref|, the reference being minimal-coordinate collocation "
                f"derived separately (ocp_suite_minimal*.py) on twice our fine mesh's intervals; its mesh error is "
                f"|J_ref - J_half| / |J_ref| with J_half its solve on our fine mesh, and 'agreement on our fine mesh' is "
                f"|J_fine - J_half| / |J_half|." + (f" Rows of {', '.join(earlier)} are from an earlier run into the same "
                                                    f"folder." if earlier else "") + "\n\n" + markdown(rows, runs))
        write_atomic(folder / "ocp_suite.csv", csv_text(rows).encode())
        write_atomic(folder / "ocp_suite.md", text.encode())
        if readme is not None:
            splice(Path(readme), text)
        return rows

    for sp in PROBLEMS:
        if only and sp.name not in only:
            continue
        log(f"== {sp.name}")
        new[sp.name] = run_problem(sp, N, runs, log, fine_mesh, coordinates)
        rows = write()
    if readme is not None:
        log(f"  {readme}: the suite's table replaced")
    minutes = (time.perf_counter() - started) / 60
    log(f"ocp suite finished in {minutes:.1f} min; results in {folder}")
    return rows


def _earlier_rows(folder, exclude: set) -> dict:
    """The rows of ``folder``'s ``ocp_suite.csv`` (an earlier run) for the problems not in ``exclude``."""
    path = folder / "ocp_suite.csv"
    if not path.exists():
        return {}

    def value(text: str):
        if text in ("True", "False"):
            return text == "True"
        for kind in (int, float):
            try:
                return kind(text)
            except ValueError:
                pass
        return text

    with path.open() as fh:
        return {r["problem"]: {k: value(v) for k, v in r.items()} for r in csv.DictReader(fh) if r["problem"] not in exclude}


def splice(readme, text: str | None) -> None:
    """Replace the text between the suite markers of ``readme``; ``text=None`` only checks them."""
    from ..output.files import replace_between_markers

    replace_between_markers(Path(readme), SUITE_START, SUITE_END, text, "bench --ocp-suite --readme")
