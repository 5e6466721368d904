"""``ocp-constraints bench --ocp-suite``: the user-problem suite, ours against rockit and a reference.

Per problem (:data:`PROBLEMS`):

1. ours: the problem of :mod:`.ocp_suite` / :mod:`.ocp_suite_3d`, from its user-level guess, Radau
   degree 3 on ``N`` intervals, built and solved ``runs`` times from scratch (median time: from
   an empty model to the solution, so the equations' derivation and the NLP's build count), once
   in maximal coordinates (the default) and once with ``coordinates="joint"``;
2. rockit: the minimal-coordinate problem of :mod:`.ocp_suite_minimal` in rockit, the same
   degree and ``N``, from the same guess (median time: from an empty ``rockit.Ocp`` to the solution);
   the three alternate run by run, so they see the same machine load;
3. accuracy (:mod:`.ocp_suite_convergence`): ours (in the form pinned per problem) and the
   minimal-coordinate reference by the plain collocation of :mod:`.ocp_suite_peers` on a chain of
   meshes, Radau 7 with doubling ``N``, ours warm-started from the previous mesh (the first from
   the coarse solution), the reference from ours on the same mesh mapped into minimal coordinates
   (the same local optimum), until the reference has converged; our deviation from it on every mesh.

Times are wall (``*_s``) and CPU (``*_cpu_s``) seconds of this process. Results: ``ocp_suite.csv``
(one row per problem), ``ocp_suite.chain.csv`` (one row per problem and mesh) and ``ocp_suite.md``.
"""
from __future__ import annotations

import csv
import io
import statistics
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable


from . import ocp_suite as planar
from . import ocp_suite_3d as spatial
from . import ocp_suite_minimal as minimal
from . import ocp_suite_minimal_3d as minimal3d
from . import ocp_suite_maps as maps
from .ocp_suite_convergence import TARGET, chain, converge
from .ocp_suite_peers import solve_rockit
from .peers import available


@dataclass
class SuiteProblem:
    name: str
    ours: Callable
    minimal: Callable
    guess: str                               # the user-level guess, in words
    fine: tuple[int, int]                    # the accuracy chain's first mesh: (intervals, Radau degree)
    finest: int                              # ... and its largest number of intervals (doubling from fine)
    fine_coordinates: str                    # our form on the chain (pinned: the default 'auto' may change)
    states: Callable | None = None           # our solution -> minimal states and controls
    inputs: list[str] = field(default_factory=list)   # our inputs in the minimal control order (same signs)


WALKER_LINKS = [f"{n}.psi" for n in spatial.LINKS]
# The chains start where the reference's changes are already small (acrobot and four-bar: at
# N = 20 their optima are not yet resolved) and end where it has converged to CONVERGED
# (measured: acrobot 1.2e-9 at N = 320, four-bar 1.1e-8 at 640, the others <= 1e-8 by 160).
# Joint coordinates where 'auto' picks them; the disk and the quadrotor (no library joints) maximal.
PROBLEMS = [
    SuiteProblem("acrobot", planar.acrobot, minimal.acrobot, "none", (40, 7), 320, "joint",
                 maps.angles(["upper.psi", "lower.psi"]), ["elbow_motor"]),
    SuiteProblem("cart_double_pendulum", planar.cart_double_pendulum, minimal.cart_double_pendulum, "none", (20, 7),
                 320, "joint", maps.angles(["cart.x", "rod1.psi", "rod2.psi"]), ["push"]),
    SuiteProblem("four_bar", planar.four_bar, minimal.four_bar, "rocker angle upright (one coordinate)", (40, 7),
                 640, "joint", maps.angles(["crank.psi"]), ["motor"]),
    SuiteProblem("rolling_disk", spatial.rolling_disk, minimal3d.rolling_disk, "none", (20, 7), 320, "maximal",
                 maps.disk_states, ["tau_x", "tau_y", "tau_z"]),
    SuiteProblem("quadrotor_load", spatial.quadrotor_load, minimal3d.quadrotor_load, "none", (20, 7), 320, "maximal",
                 maps.quadrotor_states, ["f1", "f2", "f3", "f4"]),
    SuiteProblem("walker", spatial.walker, minimal3d.walker, "none", (20, 7), 320, "joint",
                 maps.angles(WALKER_LINKS, [-1.0] * 5), ["ankle", "hip1", "hip2", "knee1", "knee2"]),
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
    of the accuracy chain's first mesh instead of the problem's own, the chain then being that mesh,
    twice and four times its intervals; ``coordinates``: with ``"joint"``, our problem is also
    solved (and timed) in joint coordinates."""
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
    # The accuracy chain in the form pinned for the problem, from the coarse solution of that form.
    problem, coarse = {"maximal": kept, "joint": kept_joint}.get(sp.fine_coordinates) or (None, None)
    if problem is None:
        problem = sp.ours(coordinates=sp.fine_coordinates)
    meshes = chain(fine_mesh, 4 * fine_mesh[0]) if fine_mesh else chain(sp.fine, sp.finest)
    row.update(converge(sp, mp, problem, coarse, meshes, log, _stop_if_interrupted))
    row["fine_setting"] += f", {problem.nlp_coordinates} coordinates"
    log(f"  {sp.name}: reference J = {row['reference_objective']:.12g} ({row['reference_setting']}, changed by "
        f"{row['reference_change']:.1e} over the last doubling); ours within {TARGET:.0e} from "
        f"{row['within_target_from']}; deviations {row['deviations']}")
    return row


RUN_FIELDS = ["success", "status", "iterations", "objective", "solve_s", "cpu_s", "ipopt_s"]
COLUMNS = (["problem", "guess", "N"] + [f"{w}_{k}" for w in ("ours", "joint", "rockit") for k in RUN_FIELDS]
           + ["fine_setting", "fine_success", "fine_objective", "fine_s", "fine_cpu_s", "reference_setting",
              "reference_success", "reference_objective", "reference_change", "reference_ratio", "reference_tail",
              "reference_s", "reference_cpu_s", "within_target_from", "deviations", "agreement", "agreement_equal_mesh"])
CHAIN_COLUMNS = ["problem", "mesh", "N", "degree", "ours_success", "ours_iterations", "ours_objective", "ours_s",
                 "ours_cpu_s", "ref_success", "ref_iterations", "ref_objective", "ref_s", "ref_cpu_s", "deviation", "equal_mesh"]


def csv_text(rows: list[dict], columns: list[str] = COLUMNS) -> str:
    buf = io.StringIO()
    w = csv.DictWriter(buf, columns, extrasaction="ignore")
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
    head = ("| problem | guess | maximal: success, iterations | maximal: time s (CPU s) | maximal: J | joint coordinates: "
            "success, iterations | joint: time s (CPU s) | joint: J | rockit: success, iterations | rockit: time s (CPU s) "
            "| rockit: J | time / rockit's, maximal (CPU) | joint (CPU) | converged reference J (finest mesh; its change "
            "over the last doubling) | ours: deviation from it at N = | ours within 1e-6 from | the two forms on the same "
            "mesh (largest difference) |")
    lines = [head, "|" + "---|" * 17]
    for r in rows:
        lines.append(
            f"| {r['problem']} | {r['guess']} | {_cell(r, 'ours')} | {_cell(r, 'joint')} | {_cell(r, 'rockit')} | "
            f"{_ratio(r, 'ours', 'solve_s')} ({_ratio(r, 'ours', 'cpu_s')}) | "
            f"{_ratio(r, 'joint', 'solve_s')} ({_ratio(r, 'joint', 'cpu_s')}) | "
            f"{r['reference_objective']:.12g} ({r['reference_setting'].replace('minimal-coordinate ', '')}"
            f"{'' if r['reference_success'] else ', a solve failed'}; {r['reference_change']:.1e}) | {r['deviations']}"
            f"{'' if r['fine_success'] else ' (a solve failed)'} | {r['within_target_from']} | "
            f"{r['agreement_equal_mesh']:.1e} |")
    return "\n".join(lines) + "\n"


def chain_markdown(steps: list[dict]) -> str:
    """The accuracy chains: one line per problem and mesh."""
    lines = ["| problem | mesh | ours: J | ours: iterations, time s (CPU s) | reference: J | reference: iterations, "
             "time s (CPU s) | ours vs the converged reference | ours vs the reference on this mesh |",
             "|" + "---|" * 8]
    for s in steps:
        ok = {True: "", False: " (failed)"}
        lines.append(f"| {s['problem']} | {s['mesh']} | {s['ours_objective']:.12g}{ok[s['ours_success']]} | "
                     f"{s['ours_iterations']}, {s['ours_s']:.1f} ({s['ours_cpu_s']:.1f}) | {s['ref_objective']:.12g}"
                     f"{ok[s['ref_success']]} | {s['ref_iterations']}, {s['ref_s']:.1f} ({s['ref_cpu_s']:.1f}) | "
                     f"{s['deviation']:.1e} | {s['equal_mesh']:.1e} |")
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
        """The tables so far (after every problem, so an interrupted run keeps what it has)."""
        # Read now: another run may have written them meanwhile. Rows of an older layout are dropped.
        earlier = {r["problem"]: r for r in _earlier_rows(folder / "ocp_suite.csv", set(new)) if set(COLUMNS) <= set(r)}
        rows = [new.get(sp.name, earlier.get(sp.name)) for sp in PROBLEMS if sp.name in new or sp.name in earlier]
        old_steps = [r for r in _earlier_rows(folder / "ocp_suite.chain.csv", set(new)) if r["problem"] in earlier]
        steps = [s for sp in PROBLEMS for s in ([{"problem": sp.name, **c} for c in new[sp.name]["chain"]]
                                                if sp.name in new else [c for c in old_steps if c["problem"] == sp.name])]
        m = machine()
        minutes = (time.perf_counter() - started) / 60
        text = (f"Regenerated by `ocp-constraints bench --ocp-suite{' --readme ' + str(readme) if readme else ''}` "
                f"({minutes:.1f} min on this machine: {m['cpus']} cores, Python {m['python']}, CasADi {m['casadi']}, "
                f"{m['date']}). Speed: medians of {runs} runs, each from an empty model to the solution, wall seconds "
                f"and in brackets CPU seconds; ours in maximal coordinates and in joint coordinates (coordinates="
                f"'maximal' / 'joint'; the default 'auto' picks joint coordinates for the four planar problems, maximal "
                f"for the disk and the quadrotor) and rockit (minimal coordinates), all Radau collocation of degree 3 "
                f"on N = {N} intervals from the same user-level guess. J: the objective. Accuracy: ours and the "
                f"minimal-coordinate problem derived separately (ocp_suite_minimal*.py, solved by plain Radau "
                f"collocation, ocp_suite_peers.collocate) on a chain of meshes, "
                f"{'Radau %d' % fine_mesh[1] if fine_mesh else 'Radau 7'} with N doubling, ours warm-started from our "
                f"previous mesh's solution, the reference from ours on the same mesh mapped into minimal coordinates (so "
                f"both are the same local optimum; each then solved to IPOPT's tol 1e-10), until the reference changes by "
                f"at most 1e-8 over a doubling (or the chain ends); the converged reference is the finest one. Deviation: |J_ours(N) - J_ref| / |J_ref|; "
                f"'within 1e-6 from': the coarsest mesh from which every finer one (below the finest) stays within."
                + (f" Rows of {', '.join(earlier)} are from an earlier run into the same folder." if earlier else "")
                + "\n\n" + markdown(rows, runs) + "\n<details><summary>The accuracy chains, mesh by mesh "
                "(results/bench/ocp_suite.chain.csv)</summary>\n\n" + chain_markdown(steps) + "\n</details>\n")
        write_atomic(folder / "ocp_suite.csv", csv_text(rows).encode())
        write_atomic(folder / "ocp_suite.chain.csv", csv_text(steps, CHAIN_COLUMNS).encode())
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


def _earlier_rows(path: Path, exclude: set) -> list[dict]:
    """The rows of ``path`` (a CSV of an earlier run) for the problems not in ``exclude``."""
    if not path.exists():
        return []

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
        return [{k: value(v) for k, v in r.items()} for r in csv.DictReader(fh) if r["problem"] not in exclude]


def splice(readme, text: str | None) -> None:
    """Replace the text between the suite markers of ``readme``; ``text=None`` only checks them."""
    from ..output.files import replace_between_markers

    replace_between_markers(Path(readme), SUITE_START, SUITE_END, text, "bench --ocp-suite --readme")
