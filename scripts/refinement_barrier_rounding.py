"""How IPOPT's barrier rounds an input's corner on a short interval (issue 19; ocp/mesh_solves.complementarity_tolerance).

    python scripts/refinement_barrier_rounding.py [--lengths 1e-2 3e-3 1e-3 3e-4 1e-4] [--complementarity 1e-13]
    python scripts/refinement_barrier_rounding.py --centred --lengths 1e-2 1e-3 3e-4 1e-4 3e-5 1e-5 --complementarity 1e-14

The first newcomer's rod (|tau| <= 0.9 N m, rest to rest, least int tau^2; ``scripts/refinement_newcomer_problems.py``,
closed form there) on fixed Radau 7 meshes: 20 equal intervals plus one interval of length ``h`` (fraction of
the horizon) from 0.1125, which holds the junction where the torque leaves its bound (0.1127), and its mirror
image at the end. Printed: the torque's largest error against the closed form on that interval and on the whole
horizon (4001 points each, relative to the bound), with IPOPT's own complementarity tolerance and with
``--complementarity``. An interior point holds the bound at mu / z from it, z the bound's multiplier, which
carries the point's quadrature weight: the rounding grows as the interval shrinks. ``--centred``: the short
interval centred on the closed form's junction instead (the kink in its middle): how short an interval a kink
inside it can be given before the solve loses precision.
"""
from __future__ import annotations

import argparse
import os
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from refinement_newcomer_problems import P3, build, reference  # noqa: E402

import ocp_constraints as oc  # noqa: E402

START = 0.1125


def torque_error(sol, f, lo: float, hi: float) -> float:
    t = np.linspace(lo, hi, 4001) * P3["T"]
    _, inputs, _ = f(t)
    return max(float(np.max(np.abs(sol.interpolate(n, t) - r))) for n, r in inputs.items()) / P3["tmax"]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--lengths", type=float, nargs="+", default=[1e-2, 3e-3, 1e-3, 3e-4, 1e-4])
    ap.add_argument("--complementarity", type=float, default=1e-13)
    ap.add_argument("--centred", action="store_true", help="the short interval centred on the junction")
    args = ap.parse_args()
    _, _, f = reference("rod_torque")
    t = np.linspace(0.05, 0.15, 200_001) * P3["T"]
    torque = next(iter(f(t)[1].values()))
    junction = t[np.argmax(np.abs(torque) < P3["tmax"] - 1e-12)] / P3["T"]
    print(f"junction at {junction:.6f} of the horizon")
    print("h (fraction) | IPOPT's own: interval / horizon | compl_inf_tol %g: interval / horizon | IPOPT iterations"
          % args.complementarity)
    for h in args.lengths:
        start = junction - h / 2 if args.centred else START
        cut = np.array([start, start + h])
        mesh = np.unique(np.round(np.concatenate([np.linspace(0, 1, 21), cut, 1 - cut]), 12))
        scheme = oc.Radau(mesh=tuple(mesh), degrees=(7,) * (len(mesh) - 1))
        row, its = [], []
        for options in (None, {"ipopt.compl_inf_tol": args.complementarity}):
            sol = build("rod_torque").solve(scheme, ipopt_options=options)
            row.append(f"{torque_error(sol, f, start, start + h):.1e} / {torque_error(sol, f, 0.001, 0.999):.1e}")
            its.append(str(sol.iterations))
        print(f"{h:g} | {row[0]} | {row[1]} | {' / '.join(its)}")


if __name__ == "__main__":
    main()
