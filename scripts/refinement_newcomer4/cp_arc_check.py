"""Is a boundary arc better than the single touch? Reference with a middle phase held on the bound, its length free >= gap."""
import json, numpy as np, nc4
xm = tuple(json.load(open("cp_bound.json"))["xmax"])
f = nc4.load_ref("cartpole")
def guess(frac):
    X = np.vstack([np.interp(frac, f["frac"], f["X"][i]) for i in range(4)])
    W = np.atleast_2d(np.interp(frac, f["frac"][1:], f["W"][0])); return X, W, 2.0
ft = 0.63564293 / 2
for gap in (1e-3, 1e-2):
    N1, N2, N3 = 13, 4, 27
    nc4.PHASE_GAP = gap; nc4.ARC = (N1, N1 + N2, 0, xm[1])
    s, r = nc4.cp_reference(N1 + N2 + N3, 7, guess=guess, xmax=xm, touch=None) if False else (None, None)
    s = nc4.cp_system()
    fx = nc4.ca.Function("fx", [nc4.ca.vertcat(s.q, s.qd), s.w], [s.q[0]])
    r = nc4.radau(s, N1 + N2 + N3, 2.0, lambda x, w, t: nc4.ca.sumsqr(w), {0: 0, 1: 0, 2: 0, 3: 0}, {0: 0, 1: np.pi, 2: 0, 3: 0},
                  degree=7, guess=guess, path=[(fx, -xm[0], xm[1])],
                  phases=[(N1, ft - gap / 4, None), (N2, ft + gap, None), (N3, None, None)])
    mesh = r["frac"][::7]
    print(f"min arc length {gap * 2:.0e} s: objective {r['objective']:.10f} arc [{mesh[N1] * 2:.6f}, {mesh[N1 + N2] * 2:.6f}] s "
          f"(touch reference {f['objective']:.10f})")
