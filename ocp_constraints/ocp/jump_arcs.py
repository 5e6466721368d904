"""Bang-bang inputs: their arcs imposed, each jump a mesh point whose time is an NLP variable (issue 19).

An input that no effort term holds (:func:`.switch_detection.penalized_inputs`) and that sits on one of its bounds at
every point but next to its jumps is bang-bang (a least-time push, a least-fuel thruster). Next to a jump only the
bounds' barrier holds it, and the NLP trades the jump's time against barrier-sized values at almost no cost: on a mesh
point at the located switch the jump was left 1e-6 to 2e-5 s off the closed form's (the twelfth newcomer's least-fuel
slider), and 1e-6 was not met. Nor can the secant of :mod:`.junction_times` place it: a jump has no continuity
mismatch to find the root of, and with both sides held at their bounds and the jump's time fixed the NLP is
overconstrained (the final conditions fix the jump times).

So the refinement (:mod:`.mesh_refinement`, step 6) imposes such an input's arcs, held at their bounds on every point
(no free interval between them: :func:`.imposed_arcs.pinned_points`), and makes each jump a mesh point whose time is
the optimizer's (:mod:`.free_mesh_points`): one solve places it, to IPOPT's tolerance. The arcs are kept where they
hold (:func:`.junction_times.holds`: each arc's bound multiplier pushes the input against its bound); every later
solve, the companion's too, places its own jumps so.
"""
from __future__ import annotations

import numpy as np

from .free_mesh_points import freed_at
from .imposed_arcs import Arc, inner_junctions
from .mesh_solves import timed_solve
from .switch_detection import activity, bounded_quantities, detect_switches, penalized_inputs

# Points of an arc allowed off its bound (the NLP smears a jump over the points of its bracket, a few on each side).
LOOSE_POINTS = 2


def find_jumps(solution) -> tuple[list[Arc], dict[str, float]]:
    """The arcs of every bang-bang input (module notes), their ends at its located jumps, and each such input's scale
    (its bounds' largest magnitude); none for an input that is off its bounds elsewhere (a singular or free arc)."""
    tr = solution.transcription
    pr = getattr(tr, "user_problem", tr.problem)
    jumps = [w for w in detect_switches(solution) if w.kind == "bang-bang" and w.source == "input"]
    if not jumps:
        return [], {}
    smooth, t, arcs, scale = penalized_inputs(solution), tr.fractions, [], {}
    for name, v, lo, hi, state, _ in bounded_quantities(solution):
        at = sorted(w.fraction for w in jumps if w.quantity == name)
        if state or name not in pr.model.inputs or name in smooth or not at:
            continue
        s, _ = activity(v, lo, hi)
        edges, pieces = [0.0, *at, 1.0], []
        for a, b in zip(edges[:-1], edges[1:]):
            inside = s[1:][(t[1:] > a) & (t[1:] < b)]       # t = 0: Radau's extrapolated input
            signs = set(inside[inside != 0].tolist())
            if len(signs) != 1 or np.count_nonzero(inside == 0) > 2 * LOOSE_POINTS:
                break
            pieces.append(Arc(name, float(lo if signs.pop() < 0 else hi), float(a), float(b)))
        if len(pieces) == len(edges) - 1 and all(p.value != q.value for p, q in zip(pieces, pieces[1:])):
            arcs += pieces
            scale[name] = max(abs(lo), abs(hi))
    return arcs, scale


def solve_jumps(problem, scheme, arcs: tuple, options: dict, warm, progress, first, fallback, scale_objective):
    """Solve ``scheme`` with the bang-bang ``arcs`` imposed, each jump a free mesh point (module notes). Returns
    ``(solution, wall s, CPU s, mesh, arcs)``: the mesh and arcs at the solved jump times."""
    times = sorted({at for _, _, at in inner_junctions(list(arcs))})
    sol, wall, cpu = timed_solve(problem, freed_at(scheme, times), options, warm, progress, first, fallback,
                                 scale_objective, arcs=arcs)
    return sol, wall, cpu, sol.transcription.scheme, tuple(sol.transcription.arcs)
