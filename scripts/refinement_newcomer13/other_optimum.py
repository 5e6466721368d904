"""The five-bar at 1e-7 ended on another local optimum (objective 0.8403 against 6.8163): solve the reference
(one phase, the ceiling as an inequality at the collocation points, degree 7) from the library's 1e-7 solution
(sol_fivebar_1e-07.npz) at N and 2N intervals, and compare.   python other_optimum.py N"""
import json
import pickle
import sys

import numpy as np

import fivebar_ref as fr
from models import FB

N = int(sys.argv[1]) if len(sys.argv) > 1 else 60
z = np.load("sol_fivebar_1e-07.npz")
t = z["t"]
X = np.vstack([z["lib:crank1.psi"], z["lib:crank2.psi"], z["lib:crank1.omega_z"], z["lib:crank2.omega_z"]])
U = np.vstack([z["libu:tau1"], z["libu:tau2"]])
H = fr.h_line()
a, b = FB["a"], FB["b"]
yP = a * np.sin(z["lib:crank1.psi"]) + b * np.sin(z["lib:coupler1.psi"])
print("library 1e-7 solution: max y_P", yP.max(), "min crank2", X[1].min(), "int tau^2", np.trapezoid((U**2).sum(0), t))
out = {}
for n in (N, 2 * N):
    r = fr.solve([n], True, (t, X, U, [1.0]), H)
    D = fr.Dense(r)
    Xr, Ur = D(t)
    out[n] = r
    print(n, r["status"], r["iters"], "J", r["J"], "max |theta - lib|", np.abs(Xr[:2] - X[:2]).max(),
          "max |omega - lib|", np.abs(Xr[2:] - X[2:]).max(), "max |tau - lib| / max|tau|",
          np.abs(Ur - U).max() / np.abs(Ur).max(), flush=True)
D1, D2 = fr.Dense(out[N]), fr.Dense(out[2 * N])
X1, _ = D1(t)
X2, _ = D2(t)
print("reference N vs 2N, states", np.abs(X1 - X2).max())
pickle.dump({"fine": out[2 * N], "coarse": out[N]}, open("ref_fivebar_other.pkl", "wb"))
