"""Build the reference of one problem: python ref.py PROBLEM  (-> ref_PROBLEM.npz)."""
import json, math, os, sys, time
import numpy as np, casadi as ca
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import nc4
import ocp_constraints as oc

P = sys.argv[1]
HERE = nc4.HERE


def interp(ref, vals, fq, degree, skip_first=False):
    """Per-interval Lagrange through the interval's start and collocation nodes (start node of interval 0 left
    out when skip_first)."""
    N = (len(ref["frac"]) - 1) // degree
    mesh = ref["frac"][::degree]
    out = np.zeros(len(fq))
    k = np.clip(np.searchsorted(mesh, fq, side="right") - 1, 0, N - 1)
    for i, (f, kk) in enumerate(zip(fq, k)):
        idx = np.arange(kk * degree, kk * degree + degree + 1)
        if skip_first and kk == 0:
            idx = idx[1:]
        xs, ys = ref["frac"][idx], vals[idx]
        val = 0.0
        for j in range(len(xs)):
            lj = np.prod([(f - xs[r]) / (xs[j] - xs[r]) for r in range(len(xs)) if r != j])
            val += ys[j] * lj
        out[i] = val
    return out


cfg = {"fourbar": (nc4.fb_reference, nc4.fb_ref_quantities, 7, 100, ["crank.psi"]),
       "dpend": (nc4.dp_reference, nc4.dp_ref_quantities, 7, 100, ["a.psi", "b.psi"]),
       "cartpole": (None, nc4.cp_ref_quantities, int(os.environ.get("DREF", 7)), int(os.environ.get("NREF", 40)), ["cart.x", "pole.psi"]),
       "arm": (nc4.arm_reference, nc4.arm_ref_quantities, 3, int(os.environ.get("NREF", 1000)), ["rod.psi"])}
reffn, qfn, deg, N, qnames = cfg[P]

if P == "cartpole":
    bpath = os.path.join(HERE, "cp_bound.json")
    if not os.path.exists(bpath):
        s0 = nc4.cartpole_model(None).solve(oc.Radau(40, degree=3))
        x = s0.sample("cart.x")
        print("unbounded cart.x range", x.min(), x.max(), "objective", s0.objective)
        if x.max() >= -x.min():
            xm = [10.0, round(0.7 * x.max(), 3)]
        else:
            xm = [round(-0.7 * x.min(), 3), 10.0]
        json.dump({"xmax": xm, "unbounded_range": [float(x.min()), float(x.max())]}, open(bpath, "w"))
    xm = tuple(json.load(open(bpath))["xmax"])
    def reffn(N, degree, guess=None):
        tl = lib.t; xl = np.asarray(lib.sample("cart.x")); ft = float(tl[np.argmax(xl)] / 2.0)
        N1 = int(round(N * ft))
        print("touch guess fraction", ft, "N1", N1)
        return nc4.cp_reference(N, degree, guess, xmax=xm, touch=(N1, ft, {0: xm[1], 2: 0.0}))

if P == "arm" and os.environ.get("PHASES"):
    f1, f2 = [float(v) for v in os.environ["PHASES"].split(",")]   # junction fractions of T (guesses)
    def reffn(N, degree, guess=None):
        n1, n3 = max(2, int(round(N * f1))), max(2, int(round(N * (1 - f2))))
        ph = [(n1, f1, nc4.ARM["tau_max"]), (N - n1 - n3, f2, None), (n3, None, -nc4.ARM["tau_max"])]
        pins = [(n1, "start", nc4.ARM["tau_max"]), (N - n3 - 1, "end", -nc4.ARM["tau_max"])]
        return nc4.arm_reference(N, degree, guess, phases=ph, pins=pins)
    deg, N = int(os.environ.get("DREF", 7)), int(os.environ.get("NREF", 40))
ocp = nc4.build(P)
print(ocp.model.describe())
c0 = time.process_time()
lib = ocp.solve(oc.Radau(40, degree=3))
T_lib = float(lib.t_final) if hasattr(lib, "t_final") else float(lib.t[-1])
print("library R3N40:", lib.status, lib.objective, "T", T_lib, "cpu", time.process_time() - c0, ocp.nlp_coordinates)


def guess(frac):
    t = frac * T_lib
    qs = [np.asarray(lib.interpolate(n, t)) for n in qnames]
    rates = [np.asarray(lib.interpolate(n.replace("psi", "omega_z").replace("cart.x", "cart.vbar_x"), t)) for n in qnames]
    ins = [np.asarray(lib.interpolate(n, np.maximum(t, 1e-9))) for n in ocp.model.inputs]
    return np.vstack(qs + rates), np.vstack(ins), T_lib


refs = []
for n in (N, 2 * N):
    c0 = time.process_time()
    s, r = reffn(n, deg, guess=guess)
    print(f"reference N={n} degree {deg}: objective {r['objective']:.12g} T {r['T']:.10g} iters {r['iterations']} "
          f"cpu {time.process_time() - c0:.1f}")
    r["q"] = qfn(s, r)
    refs.append(r)
coarse, fine = refs
_, states, mult = nc4.SPEC[P]
# accuracy: the fine one interpolated at the coarse one's points (same fraction of T)
acc_s = 0.0
for n in states:
    d = interp(fine, fine["q"][n], coarse["frac"], deg) - coarse["q"][n]
    if n.endswith("psi") or n == "el.angle":
        d = (d + np.pi) % (2 * np.pi) - np.pi
    acc_s = max(acc_s, float(np.abs(d).max()))
peak = max(float(np.abs(fine["q"][n][1:]).max()) for n in mult)
acc_m = 0.0
for n in mult:
    d = interp(fine, fine["q"][n], coarse["frac"][1:], deg, skip_first=True) - coarse["q"][n][1:]
    acc_m = max(acc_m, float(np.abs(d).max()) / peak)
fine["accuracy"] = {"states_coarse_vs_fine": acc_s, "multipliers_coarse_vs_fine_rel_peak": acc_m,
                    "objective_coarse": coarse["objective"], "objective_fine": fine["objective"],
                    "T_coarse": coarse["T"], "T_fine": fine["T"], "N": [N, 2 * N], "degree": deg,
                    "ne_residual": float(fine["q"].get("_ne_residual", 0.0)), "peak_load": peak,
                    "lib_R3N40_objective": float(lib.objective)}
print(json.dumps(fine["accuracy"]))
# a check of the library reading against loads() at its own points (sign / basis of the multipliers)
np.savez(os.path.join(HERE, f"ref_{P}.npz"), ref=np.array(fine, dtype=object))
