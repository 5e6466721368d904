"""Check the fuel references: states by integrating the reference's own input (DOP853, rtol 1e-13, breakpoints at the
switches/junctions) against the closed-form states; and the regularised optimum's stationarity by a perturbation of beta."""
import numpy as np
from scipy.integrate import solve_ivp
import reference
from models import PARAMS

P = PARAMS["fuel"]
T, m = P["T"], P["m"]
for reg in (0.0, 1e-3):
    kw = dict(reg=reg) if reg else {}
    tt = np.linspace(0, T, 4001)
    st, lam, inp, info = reference.evaluate("fuel", tt, **kw)
    br = [0.0] + [j for j in info["junctions"]] + [T]
    x0, err = [0.0, 0.0], 0.0
    for a, b in zip(br[:-1], br[1:]):
        f = lambda t, z: [z[1], (reference.evaluate("fuel", np.array([t]), **kw)[2]["up"][0]
                                 - reference.evaluate("fuel", np.array([t]), **kw)[2]["um"][0]) / m]
        sel = (tt >= a) & (tt <= b)
        s = solve_ivp(f, (a, b), x0, method="DOP853", rtol=1e-13, atol=1e-14, dense_output=True)
        y = s.sol(tt[sel])
        err = max(err, np.abs(y[0] - st["slider.x"][sel]).max(), np.abs(y[1] - st["slider.vbar_x"][sel]).max())
        x0 = s.y[:, -1]
    print(f"reg {reg:g}: closed form vs integrated input: states {err:.2e}; x(T) = {x0[0]:.15f}, v(T) = {x0[1]:.1e}; "
          f"objective {info['objective']:.12f}; switches {np.round(info['junctions'], 12).tolist()}")
