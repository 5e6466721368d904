"""Where the library's refined cart-pole touches the bound, against the reference's touch point."""
import sys, json, numpy as np, nc4
tol = float(sys.argv[1])
xm = json.load(open("cp_bound.json"))["xmax"][1]
sol = nc4.build("cartpole").solve(tolerance=tol)
t, x = np.asarray(sol.t), np.asarray(sol.sample("cart.x"))
on = x > xm - 1e-6
print("library points on the bound (t):", np.round(t[on], 5), "objective", sol.objective)
ref = nc4.load_ref("cartpole")
print("reference touch:", ref["t"][ref["X"][0] > xm - 1e-7], "objective", ref["objective"])
for tt in (0.3, 0.6, 0.635, 0.7, 0.73, 0.8, 1.0, 1.5):
    k = np.argmin(abs(ref["t"] - tt))
    print(f"t={ref['t'][k]:.4f} pole.omega_z lib {float(sol.interpolate('pole.omega_z', [ref['t'][k]])[0]):+.5f} ref {ref['X'][3, k]:+.5f}"
          f"  cart.x lib {float(sol.interpolate('cart.x', [ref['t'][k]])[0]):+.5f} ref {ref['X'][0, k]:+.5f}")
