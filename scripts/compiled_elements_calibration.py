"""The constants of ``ocp/compiled_elements.py`` measured, and what compiling does to a heavy solve.

    python scripts/compiled_elements_calibration.py [--runs 3] [--intervals 40] [--degree 5]
        [--out results/bench/compiled_elements.md] [--o1-limit 80000]

1. Per element derivative function of two problems (the pendulum swing-up, and the UR5 of
   ``examples/robot_arm_urdf.py`` when ``example-robot-data`` is installed), mapped over its instances
   on Radau(``intervals``, ``degree``): operations, the virtual machine's time per operation, and
   for -O1 and -O0 (fresh, in a temporary cache) the compile time per operation and the compiled
   code's time per operation (medians of ``runs`` evaluations of the mapped function).
   ``--o1-limit``: functions with more operations are not compiled at -O1 here (the UR5 point Hessian,
   70,855 operations, takes ~45 s).
2. The UR5 solve on that mesh with ``compiled="never"`` and ``compiled="always"`` (cache warm: the
   copies of step 1), alternately, CPU medians of ``runs`` (``time.process_time`` of ``problem.solve``,
   the problem built anew each run), IPOPT iterations and objectives side by side.

Benchmarks measure this machine; they are not tests.
"""
from __future__ import annotations

import argparse
import os
import statistics
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "scripts"))


#: Functions with fewer operations are left out of the table: their time is the call's, not the operations'.
MIN_OPERATIONS = 1000


def _problems() -> dict:
    from ocp_constraints.scenes.registry import build_task

    out = {"pendulum swing-up": lambda: build_task("pendulum", "swing_up")[1]}
    try:
        import ocp_default_robustness as odr

        odr._robot_arm()
        out["UR5 (examples/robot_arm_urdf.py)"] = odr._robot_arm
    except (SystemExit, ImportError, ModuleNotFoundError) as exc:
        print(f"UR5 left out: {exc}", file=sys.stderr)
    return out


def _median_seconds(f, args, runs: int) -> float:
    f(*args)
    times = []
    for _ in range(runs):
        t = time.perf_counter()
        f(*args)
        times.append(time.perf_counter() - t)
    return statistics.median(times)


def functions_table(build, scheme, runs: int, o1_limit: int) -> list[dict]:
    import numpy as np

    from ocp_constraints.dynamics.compiled import FLAGS, FLAGS_QUICK, compiled

    problem = build()
    problem.compiled = "never"
    block = problem.transcription(scheme).block
    rows, rng = [], np.random.default_rng(0)
    for el in block.elements:
        d = block._derivatives(el)
        for kind in ("jac", "grad", "hess"):
            if d[kind] is None:
                continue
            f, K = d[kind][0], el.instances
            n = f.n_instructions()
            args = [rng.uniform(-1, 1, (f.size1_in(i), K)) for i in range(f.n_in())]
            vm = _median_seconds(f.map(K), args, runs)
            row = {"function": f.name(), "operations": n, "instances": K, "vm_ns": vm / (n * K) * 1e9}
            for label, flags in (("O1", FLAGS), ("O0", FLAGS_QUICK)):
                if label == "O1" and n > o1_limit:
                    continue
                started = time.perf_counter()
                g = compiled(f, flags=flags)
                row[f"{label}_compile_s_per_op"] = (time.perf_counter() - started) / n
                row[f"{label}_ns"] = _median_seconds(g.map(K), args, runs) / (n * K) * 1e9
            rows.append(row)
    return rows


def solve_table(build, scheme, runs: int) -> dict:
    out = {"never": [], "always": []}
    info = {}
    warm = build()                  # the copies as the library looks them up (by content hash), compiled once here
    warm.compiled = "always"
    warm.transcription(scheme)
    for _ in range(runs):
        for policy in ("never", "always"):
            problem = build()
            problem.compiled = policy
            started = time.process_time()
            sol = problem.solve(scheme)
            out[policy].append(time.process_time() - started)
            info[policy] = (sol.stats["iter_count"], sol.objective)
    return {p: (statistics.median(v), *info[p]) for p, v in out.items()}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--intervals", type=int, default=40)
    ap.add_argument("--degree", type=int, default=5)
    ap.add_argument("--o1-limit", type=int, default=80_000)
    ap.add_argument("--out", type=Path, default=ROOT / "results" / "bench" / "compiled_elements.md")
    args = ap.parse_args()
    os.environ["XDG_CACHE_HOME"] = tempfile.mkdtemp(prefix="ocp_compiled_calibration_")   # fresh compiles
    import ocp_constraints as oc

    scheme = oc.Radau(args.intervals, degree=args.degree)
    started = time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime())
    lines = [f"# Element derivatives: virtual machine vs machine code", "",
             f"`python scripts/compiled_elements_calibration.py --runs {args.runs} --intervals {args.intervals} "
             f"--degree {args.degree} --o1-limit {args.o1_limit}` ({started}, load average "
             f"{os.getloadavg()[0]:.1f} on {os.cpu_count()} cores). Times per operation and instance; compile "
             f"times per operation, fresh cache; functions of at least {MIN_OPERATIONS:,} operations (below, the "
             "time is the call's, not the operations').", "",
             "| problem | function | operations | instances | VM ns/op | -O1 ns/op | -O1 compile ms/op | -O0 ns/op | -O0 compile ms/op |",
             "|---|---|---|---|---|---|---|---|---|"]
    solves = {}
    for name, build in _problems().items():
        for r in functions_table(build, scheme, args.runs, args.o1_limit):
            if r["operations"] < MIN_OPERATIONS:
                continue
            def cell(key, scale=1.0, fmt="{:.2f}"):
                return fmt.format(r[key] * scale) if key in r else "-"
            lines.append(f"| {name} | {r['function']} | {r['operations']:,} | {r['instances']} | {r['vm_ns']:.2f} | "
                         f"{cell('O1_ns')} | {cell('O1_compile_s_per_op', 1e3, '{:.3f}')} | {cell('O0_ns')} | "
                         f"{cell('O0_compile_s_per_op', 1e3, '{:.3f}')} |")
            print(lines[-1], flush=True)
        if name.startswith("UR5"):
            solves[name] = solve_table(build, scheme, args.runs)
    if solves:
        lines += ["", f"Whole solves on Radau({args.intervals}, degree={args.degree}), problem built anew each run, "
                  f"alternating, CPU medians of {args.runs}; `always` loads copies compiled once before the timed runs:", "",
                  "| problem | never: CPU s / iterations / objective | always: CPU s / iterations / objective | ratio |",
                  "|---|---|---|---|"]
        for name, s in solves.items():
            (a, ia, oa), (b, ib, ob) = s["never"], s["always"]
            lines.append(f"| {name} | {a:.2f} / {ia} / {oa:.10g} | {b:.2f} / {ib} / {ob:.10g} | {a / b:.2f} |")
            print(lines[-1], flush=True)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text("\n".join(lines) + "\n")
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
