"""Benchmark of accuracy on request (issue 19): hp mesh refinement against fixed meshes.

    python -m ocp_constraints.bench.mesh_refinement [--runs 3] [--out results/bench/mesh_refinement.md] [--skip-switching]

1. Pendulum swing-up, tolerances 1e-4, 1e-6, 1e-8: the refined solve's true error against the
   Pontryagin extremal (:func:`~ocp_constraints.bench.references.swing_up_reference`, shooting and
   DOP853: an independent method), its estimate, and its total time (every refinement's solves,
   medians of ``runs``), beside a fixed-mesh sweep of Radau degree x intervals in the same run:
   the cheapest fixed mesh whose true error meets the tolerance.
2. Minimum-time swing-up (|tau| <= 5 N m, bang-bang) and the rolling-disk drive (friction cone
   switching): the final hp mesh (where its intervals are) against uniform Radau meshes of the
   same accuracy, errors against fine solutions on other meshes (named in the table): the discretization's.

Errors are measured the same way for every row (:func:`~ocp_constraints.ocp.error_estimate.compare`): states
(coordinates and speeds) absolute in SI units, multipliers relative to the reference's largest load, both the
largest over a grid of 4 times per collocation point in normalized time, multipliers without ``t = 0``. Times:
wall (``time.perf_counter``) and CPU (``time.process_time``) of the whole ``problem.solve`` call, transcription
and guesses included. Benchmarks measure this machine; they are not tests. Writes the table (``--out``) and the
swing-up's work-precision plot beside it (``.png``).
"""
from __future__ import annotations

import argparse
import os
import statistics
import sys
import time
from pathlib import Path

import numpy as np

from ..errors import OCPSolveError
from ..ocp.error_estimate import compare, names, truth_samples, values_at
from ..ocp.problem import OptimalControlProblem
from ..ocp.schemes import Radau
from ..scenes.registry import build_task
from .references import junction_mesh_solution, swing_up_reference

TOLERANCES = (1e-4, 1e-6, 1e-8)
FIXED_DEGREES = (3, 4, 5, 6, 7, 8, 9)
FIXED_INTERVALS = (5, 10, 20, 40, 80, 160)
MAX_FIXED_POINTS = 700


def _task(scene: str, task: str, coordinates: str = "auto") -> OptimalControlProblem:
    """A built-in task in ``coordinates`` (default "auto"), the same for the refined solves and the fixed meshes."""
    problem = build_task(scene, task)[1]
    problem.coordinates = coordinates
    return problem


def _timed(fn):
    wall, cpu = time.perf_counter(), time.process_time()
    out = fn()
    return out, time.perf_counter() - wall, time.process_time() - cpu


def _median_run(fn, runs: int):
    results = [_timed(fn) for _ in range(runs)]
    return results[-1][0], statistics.median(r[1] for r in results), statistics.median(r[2] for r in results)


class SwingUpTruth:
    """The swing-up's states, hinge multipliers and torque from the Pontryagin extremal (all 12 states
    from ``psi``: rod centre ``L/2 (sin psi, -cos psi, 0)``, ``theta = phi = 0``, ``omega = psi' E3``)."""

    def __init__(self):
        self.ref = swing_up_reference()

    def __call__(self, sol, fractions: np.ndarray) -> dict:
        t = fractions * sol.t_final
        psi, w = self.ref.states(t)
        h, z = self.ref.L / 2, 0 * t
        X = np.array([h * np.sin(psi), -h * np.cos(psi), z, psi, z, z, h * w * np.cos(psi), h * w * np.sin(psi), z, z, z, w])
        lam = self.ref.multipliers(t)
        return {"states": X, "multipliers": np.array([lam[k] for k in names(sol)["multipliers"]]),
                "inputs": self.ref.torque(t)[None, :]}


def true_error(sol, truth) -> dict[str, float]:
    """Errors of ``sol`` against ``truth(sol, fractions)`` (a reference's values), per quantity, read on the samples
    the estimate reads (:func:`~ocp_constraints.ocp.error_estimate.truth_samples`)."""
    fractions, owner, probes = truth_samples(sol)
    est = compare(values_at(sol, fractions, probes), truth(sol, fractions), fractions, owner,
                  sol.transcription.scheme.intervals, names(sol))
    return est.totals


def _gated(errors: dict) -> float:
    return max(errors["states"], errors["multipliers"])


def minimum_time_swing_up(coordinates: str = "auto") -> OptimalControlProblem:
    """The swing-up with free final time in [0.5, 4] s, |torque| <= 5 N m, minimum time (bang-bang)."""
    _, base = build_task("pendulum", "swing_up")
    problem = OptimalControlProblem(base.model, t_final=2.0, t_final_bounds=(0.5, 4.0))
    problem.bound("motor", -5.0, 5.0)
    problem.initial({"rod.psi": 0.0, "rod.psi_dot": 0.0})
    problem.final({"rod.psi": np.pi, "rod.psi_dot": 0.0})
    problem.minimize_final_time()
    problem.set_guess("rod.psi", base.guess["rod.psi"])
    problem.coordinates = coordinates
    return problem


class MinimumTimeReference:
    """The minimum-time swing-up as one switch of the bang-bang torque, solved by shooting: the
    switch time ``t1`` and the final time ``T`` that bring the rod (``J psi'' = tau - c sin psi``,
    DOP853 at rtol 1e-13) from hanging at rest to upright at rest with ``tau = s max_torque`` up to
    ``t1`` and ``-s max_torque`` after; hinge loads from the hand-written Newton-Euler balance (as
    :class:`~ocp_constraints.bench.references.SwingUpReference`). The arc structure (one switch, the
    first sign ``s``) is read from a collocation solution: an assumption this reference does not
    prove (Pontryagin's conditions would); the states and ``T`` it gives for that structure are exact
    to the integrator's tolerance."""

    def __init__(self, seed_solution, max_torque: float = 5.0):
        from scipy.integrate import solve_ivp

        from .references import RTOL, swing_up_reference

        base = swing_up_reference()
        self.m, self.L, self.g, self.J, self.c = base.m, base.L, base.g, base.J, base.c
        tau = seed_solution.sample("motor")
        t = seed_solution.t
        self.sign = float(np.sign(tau[len(tau) // 10]))
        flips = np.flatnonzero(np.sign(tau[1:]) != np.sign(tau[:-1]))
        if len(flips) != 1 + (np.sign(tau[0]) != np.sign(tau[1])):
            raise RuntimeError(f"the seed solution's torque changes sign {len(flips)} times: one switch assumed")
        self.tau_max, self._ivp = max_torque, lambda *a, **k: solve_ivp(*a, method="DOP853", rtol=RTOL, atol=RTOL, **k)
        x = np.array([t[flips[-1]], seed_solution.t_final])
        for _ in range(30):
            r = self._end(x)
            if np.abs(r).max() < 1e-12:
                break
            Jac = np.column_stack([(self._end(x + dx) - self._end(x - dx)) / (2 * dx[k]) for k, dx in enumerate(np.eye(2) * 1e-7)])
            x = x - np.linalg.solve(Jac, r)
        if np.abs(self._end(x)).max() > 1e-10:
            raise RuntimeError(f"minimum-time reference: shooting did not converge (end residual {self._end(x)})")
        self.t1, self.t_final = x
        self.arcs = self._arcs(x)

    def _rhs(self, tau):
        return lambda t, y: [y[1], (tau - self.c * np.sin(y[0])) / self.J]

    def _arcs(self, x):
        t1, T = x
        a = self._ivp(self._rhs(self.sign * self.tau_max), (0.0, t1), [0.0, 0.0], dense_output=True)
        b = self._ivp(self._rhs(-self.sign * self.tau_max), (t1, T), a.y[:, -1], dense_output=True)
        return a, b

    def _end(self, x) -> np.ndarray:
        y = self._arcs(x)[1].y[:, -1]
        return np.array([y[0] - np.pi, y[1]])

    def truth(self, sol, fractions: np.ndarray) -> dict:
        t = fractions * sol.t_final           # the solution's own times; T differs by |T - T_ref|
        a, b = self.arcs
        y = np.where(t <= self.t1, a.sol(np.minimum(t, self.t1)), b.sol(np.maximum(t, self.t1)))
        psi, w = y
        tau = np.where(t <= self.t1, self.sign, -self.sign) * self.tau_max
        acc = (tau - self.c * np.sin(psi)) / self.J
        h, z = self.L / 2, 0 * t
        X = np.array([h * np.sin(psi), -h * np.cos(psi), z, psi, z, z, h * w * np.cos(psi), h * w * np.sin(psi), z, z, z, w])
        lam = {"hinge.v1.lambda": self.m * h * (acc * np.cos(psi) - w**2 * np.sin(psi)),
               "hinge.v2.lambda": self.m * h * (acc * np.sin(psi) + w**2 * np.cos(psi)) + self.m * self.g,
               "hinge.v3.lambda": z, "hinge.w1.lambda": z, "hinge.w2.lambda": z}
        return {"states": X, "multipliers": np.array([lam[k] for k in names(sol)["multipliers"]]), "inputs": tau[None, :]}


def swing_up_table(runs: int, log=print, coordinates: str = "auto") -> tuple[list[dict], list[dict]]:
    truth = SwingUpTruth()
    fixed = []
    for d in FIXED_DEGREES:
        for N in FIXED_INTERVALS:
            if N * d + 1 > MAX_FIXED_POINTS:
                continue
            try:
                sol, wall, cpu = _median_run(lambda: _task("pendulum", "swing_up", coordinates).solve(Radau(N, degree=d)), runs)
            except OCPSolveError as exc:
                log(f"  fixed radau{d} N={N}: {exc}")
                continue
            err = true_error(sol, truth)
            fixed.append({"setting": f"radau{d} N={N}", "points": N * d + 1, "wall_s": wall, "cpu_s": cpu, "error": _gated(err),
                          "objective": sol.objective, **err})
            log(f"  fixed radau{d} N={N}: error {_gated(err):.1e}  {wall:.2f} s wall {cpu:.2f} s cpu")
    rows = []
    for tol in TOLERANCES:
        refined = lambda: _task("pendulum", "swing_up", coordinates).solve(tolerance=tol)  # noqa: E731
        sol, wall, cpu = _median_run(refined, runs)
        mr, err = sol.mesh_refinement, true_error(sol, truth)
        ok = [f for f in fixed if f["error"] <= tol]
        best = min(ok, key=lambda f: f["cpu_s"]) if ok else None
        paired = _paired(refined, best, coordinates, runs) if best else None
        rows.append({"tolerance": tol, "met_estimate": mr["met"], "true": err, "estimate": mr["estimate"],
                     "refinements": mr["refinements"], "intervals": len(mr["degrees"]), "points": sol.transcription.scheme.point_count,
                     "degrees": f"{min(mr['degrees'])}-{max(mr['degrees'])}", "wall_s": wall, "cpu_s": cpu, "best": best,
                     "paired": paired, "coordinates": mr["coordinates"], "solves": sum(h["solves"] for h in mr["history"])})
        log(f"  tol {tol:g}: true {_gated(err):.1e} estimate {max(mr['estimate'][q] for q in ('states', 'multipliers')):.1e} "
            f"{wall:.2f} s wall {cpu:.2f} s cpu; best fixed {best and best['setting']}; interleaved {paired}")
    return rows, fixed


def _paired(refined, best: dict, coordinates: str, runs: int) -> dict:
    """The refined solve and the cheapest fixed mesh (by CPU in the sweep) timed again, alternately,
    ``runs`` times each: on a shared machine the load drifts over the sweep, and the ratio of two
    medians taken minutes apart measures the drift as much as the methods."""
    d, N = (int(v) for v in best["setting"].removeprefix("radau").split(" N="))
    fixed = lambda: _task("pendulum", "swing_up", coordinates).solve(Radau(N, degree=d))  # noqa: E731
    pairs = [(_timed(refined)[1:], _timed(fixed)[1:]) for _ in range(runs)]
    med = lambda i, j: statistics.median(p[i][j] for p in pairs)  # noqa: E731
    return {"wall_s": med(0, 0), "cpu_s": med(0, 1), "fixed_wall_s": med(1, 0), "fixed_cpu_s": med(1, 1),
            "ratio_wall": med(0, 0) / med(1, 0), "ratio_cpu": med(0, 1) / med(1, 1)}


def _where(sol) -> str:
    """The final mesh in words: the shortest intervals and where they are."""
    mesh = sol.transcription.scheme.mesh_fractions
    h = np.diff(mesh)
    short = np.argsort(h)[:4]
    spots = ", ".join(f"{mesh[k]:.4f}-{mesh[k + 1]:.4f}" for k in sorted(short))
    return f"{len(h)} intervals, widths {h.min():.1e} to {h.max():.1e} of the horizon; shortest at {spots}"


def _switching_accuracy(errors: dict, sol, ref) -> float:
    """States and final time: a jump of the inputs (and multipliers) at a switch keeps their largest
    error near the jump's size on any mesh, so they cannot rank meshes of a bang-bang solution."""
    return max(errors["states"], abs(sol.t_final - ref.t_final))


class _FineReference:
    """A fine solution on another mesh as the reference (the discretization's error only)."""

    def __init__(self, sol):
        self.sol, self.t_final = sol, sol.t_final

    def truth(self, sol, fractions):
        return values_at(self.sol, fractions)


SWITCHING = {
    "minimum-time swing-up": (lambda coordinates: minimum_time_swing_up(coordinates),
                              lambda make: MinimumTimeReference(make().solve(Radau(160, degree=3))),
                              "one-switch bang-bang by shooting (DOP853 rtol 1e-13), hand hinge loads", (1e-3, 1e-6)),
    # Mesh points at the friction cone's junctions: a uniform Radau 3 N = 800 was still 1e-4 off in the multipliers.
    "rolling_disk drive": (lambda coordinates: _task("rolling_disk", "drive", coordinates),
                           lambda make: _FineReference(junction_mesh_solution(make, make().solve(tolerance=1e-4))),
                           "radau7 N=100 plus the located cone junctions", (1e-3, 1e-4)),
    # Smooth, maximal coordinates (the drive is no library joint). Its optima come in pairs (spin one way or
    # the other, J = 0.0566 / 0.0575): the reference starts from the refined solve, the same optimum.
    "whirling spin_up": (lambda coordinates: _task("whirling", "spin_up", coordinates),
                         lambda make: _FineReference(make().solve(Radau(80, degree=8), warm_start=make().solve(tolerance=1e-4))),
                         "fine uniform radau8 N=80 from the refined solve", (1e-4, 1e-6)),
}


def switching_table(runs: int, cases=tuple(SWITCHING), log=print, coordinates: str = "auto") -> list[dict]:
    """Minimum-time swing-up and rolling-disk drive: final hp meshes vs uniform Radau 3 of the same accuracy."""
    rows = []
    for case in cases:
        build, reference, ref_label, tolerances = SWITCHING[case]
        make = lambda build=build: build(coordinates)  # noqa: E731 (one problem per solve, in the run's coordinates)
        ref = reference(make)
        truth = ref.truth

        uniform = []
        for N in (10, 20, 40, 80, 160):
            try:
                sol, wall, cpu = _median_run(lambda: make().solve(Radau(N, degree=3)), runs)
            except OCPSolveError as exc:
                log(f"  {case} uniform radau3 N={N}: {exc}")
                continue
            err = true_error(sol, truth)
            accuracy = _switching_accuracy(err, sol, ref)
            uniform.append({"setting": f"radau3 N={N}", "points": 3 * N + 1, "wall_s": wall, "cpu_s": cpu, "error": accuracy,
                            "t_final": sol.t_final, **err})
            log(f"  {case} uniform radau3 N={N}: states/T error {accuracy:.1e}, multipliers {err['multipliers']:.1e}, "
                f"{wall:.2f} s wall {cpu:.2f} s cpu")
        for tol in tolerances:
            try:
                sol, wall, cpu = _median_run(lambda: make().solve(tolerance=tol), runs)
            except OCPSolveError as exc:
                log(f"  {case} tol {tol:g}: {exc}")
                continue
            mr, err = sol.mesh_refinement, true_error(sol, truth)
            accuracy = _switching_accuracy(err, sol, ref)
            ok = [u for u in uniform if u["error"] <= accuracy]
            best = min(ok, key=lambda u: u["wall_s"]) if ok else None
            rows.append({"case": case, "tolerance": tol, "met_estimate": mr["met"], "message": mr["message"], "true": err,
                         "accuracy": accuracy,
                         "estimate": mr["estimate"], "points": sol.transcription.scheme.point_count, "where": _where(sol),
                         "wall_s": wall, "cpu_s": cpu, "uniform": best, "reference": ref_label, "t_final": sol.t_final,
                         "t_final_ref": ref.t_final, "uniform_rows": uniform, "coordinates": mr["coordinates"]})
            log(f"  {case} tol {tol:g}: states/T {accuracy:.1e}, multipliers {err['multipliers']:.1e}, estimate "
                f"{max(mr['estimate'][q] for q in ('states', 'multipliers')):.1e} {cpu:.2f} s cpu "
                f"{wall:.2f} s; {_where(sol)}; uniform {best and best['setting']}")
    return rows


def _ratio(true: float, estimate: float) -> str:
    r = true / estimate if estimate > 0 else float("inf")
    return f"{r:.2f}" + ("" if 0.1 <= r <= 1.0 else " (outside [0.1, 1])")


def markdown(swing: list[dict], fixed: list[dict], switching: list[dict], runs: int, seconds: float, command: str,
             load: float) -> str:      # command: the arguments it was run with; load: the 1-minute load average then
    out = [f"# Mesh refinement to a tolerance (issue 19)\n\n`python -m ocp_constraints.bench.mesh_refinement {command}` "
           f"({seconds / 60:.1f} min, {time.strftime('%Y-%m-%d %H:%M')}; times are medians of {runs} runs of the whole `problem.solve`, "
           f"wall and CPU; load average {load:.1f} at the start on {os.cpu_count()} cores: above 1, wall times are inflated).\n\n"
           "## Swing-up: estimates vs true errors (Pontryagin reference)\n\n"
           "Start: Radau 5, 10 intervals. Error = max(states abs., multipliers rel. to the largest load); "
           "ratio = true / estimate (the estimate is trusted when it lies in [0.1, 1]). The cheapest fixed mesh is "
           "the one of least CPU time in the sweep below among those whose true error meets the tolerance; the "
           "ratio's times are of that mesh and the refined solve timed again alternately (medians of the runs), "
           "since the load drifts over the sweep.\n\n"
           "| tolerance | coordinates | refinements (solves) | final mesh | states: true / estimate (ratio) | "
           "multipliers: true / estimate (ratio) | time wall / CPU (s) | cheapest fixed mesh meeting the tolerance "
           "| alternate runs: refined / fixed CPU (s) | ratio wall / CPU |\n"
           "|---|---|---|---|---|---|---|---|---|---|\n"]
    for r in swing:
        t, e, b, pr = r["true"], r["estimate"], r["best"], r["paired"]
        fixed_cell = "none in the sweep" if b is None else b["setting"] + f" (error {b['error']:.1e})"
        bt = "" if pr is None else f"{pr['cpu_s']:.3f} / {pr['fixed_cpu_s']:.3f}"
        ratio = "" if pr is None else f"{pr['ratio_wall']:.1f} / {pr['ratio_cpu']:.1f}"
        out.append(f"| {r['tolerance']:g} | {r['coordinates']} | {r['refinements']} ({r['solves']}) | {r['intervals']} "
                   f"intervals, degrees {r['degrees']}, {r['points']} points | {t['states']:.1e} / {e['states']:.1e} "
                   f"({_ratio(t['states'], e['states'])}) | "
                   f"{t['multipliers']:.1e} / {e['multipliers']:.1e} ({_ratio(t['multipliers'], e['multipliers'])}) | "
                   f"{r['wall_s']:.2f} / {r['cpu_s']:.2f} | {fixed_cell} | {bt} | {ratio} |\n")
    out.append("\n<details><summary>fixed-mesh sweep (same run)</summary>\n\n| setting | points | error | time wall / CPU (s) |\n|---|---|---|---|\n")
    out += [f"| {f['setting']} | {f['points']} | {f['error']:.1e} | {f['wall_s']:.2f} / {f['cpu_s']:.2f} |\n" for f in fixed]
    out.append("\n</details>\n\n## Switching solutions: final hp mesh vs uniform meshes of the same accuracy\n\n"
               "Accuracy here = max(state error, final-time error): at a switch the inputs and multipliers jump, and "
               "their largest error stays near the jump on any mesh (the multiplier column shows it).\n\n"
               "| case | tolerance | estimate met | true error (vs reference) / estimate | final mesh | time wall / CPU (s) "
               "| cheapest uniform Radau 3 with states and T as accurate | its time wall / CPU (s) | reference |\n"
               "|---|---|---|---|---|---|---|---|---|\n")
    for r in switching:
        u, t, e = r["uniform"], r["true"], r["estimate"]
        ucell = "none up to N = 160" if u is None else f"{u['setting']} ({u['points']} points, states/T {u['error']:.1e})"
        ut = "" if u is None else f"{u['wall_s']:.2f} / {u['cpu_s']:.2f}"
        out.append(f"| {r['case']} ({r['coordinates']} coordinates) | {r['tolerance']:g} | {'yes' if r['met_estimate'] else 'no: ' + r['message']} | "
                   f"states {t['states']:.1e} / {e['states']:.1e}, final time {abs(r['t_final'] - r['t_final_ref']):.1e} / "
                   f"{e.get('t_final', 0.0):.1e}, multipliers {t['multipliers']:.1e} / {e['multipliers']:.1e} | "
                   f"{r['points']} points; {r['where']} | {r['wall_s']:.2f} / {r['cpu_s']:.2f} | {ucell} | {ut} | {r['reference']} |\n")
    return "".join(out)


def plot(path: Path, swing: list[dict], fixed: list[dict]) -> None:
    """Work-precision of the swing-up: the fixed meshes (one curve per degree) and the refined solves."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7, 4.5))
    for d in FIXED_DEGREES:
        pts = sorted((f["cpu_s"], f["error"]) for f in fixed if f["setting"].startswith(f"radau{d} "))
        if pts:
            ax.loglog(*zip(*pts), "o-", ms=3, lw=1, label=f"fixed radau{d}, N = 5 ... 160")
    pts = [(r["cpu_s"], _gated(r["true"])) for r in swing]
    ax.loglog(*zip(*pts), "k*-", ms=10, label="refined to 1e-4, 1e-6, 1e-8 (all refinements)")
    for r in swing:
        ax.axhline(r["tolerance"], color="grey", lw=0.5, ls=":")
    ax.set_xlabel("CPU time of problem.solve (s, median)")
    ax.set_ylabel("true error (states abs., multipliers rel.)")
    ax.set_title("pendulum swing-up: hp refinement vs fixed Radau meshes")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=6)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--out", default="results/bench/mesh_refinement.md")
    ap.add_argument("--skip-switching", action="store_true")
    ap.add_argument("--coordinates", choices=("auto", "maximal", "joint"), default="auto",
                    help="the NLP's coordinates for every solve, refined and fixed (default: the library's auto)")
    ap.add_argument("--switching-only", nargs="*", default=None, metavar="CASE",
                    help=f"only the switching table, for these cases (default all: {', '.join(SWITCHING)})")
    args = ap.parse_args(argv)
    started, load = time.perf_counter(), os.getloadavg()[0]
    swing, fixed = swing_up_table(args.runs, coordinates=args.coordinates) if args.switching_only is None else ([], [])
    switching = [] if args.skip_switching else switching_table(args.runs, tuple(args.switching_only or SWITCHING),
                                                               coordinates=args.coordinates)
    text = markdown(swing, fixed, switching, args.runs, time.perf_counter() - started, " ".join(argv or sys.argv[1:]), load)
    path = Path(args.out)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.with_suffix(".tmp").write_text(text)
    path.with_suffix(".tmp").replace(path)      # whole or not at all
    if swing:
        plot(path.with_suffix(".png"), swing, fixed)
    print(text)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
