"""Do the eTibia loads share the motion's and the force plates' clock? (issue 15: why the predicted loading-response
peak comes early). The KCF file carries two channels recorded with the implant loads: ``GRFz``, an analog copy of a
force plate's vertical force, and ``GON``, a knee goniometer. Each is cross-correlated with its counterpart in the
other files (plate k's ``grforcek_fy`` in the GRF file; minus IK's ``knee_flexion``) over lags of -0.2..0.2 s in
1 ms steps: the KCF channel at ``t`` is compared with its counterpart at ``t + lag``, and the lag of the largest
correlation is the clock offset between the files (negative: the KCF channel is late by ``|lag|``).

    python scripts/knee_sync_check.py [--data ../shared/data/grand-challenge-knee-jw/reducepoly_subject_GC] [--trial ngait_og5]

Uses only the synchronisation channels, never the loads: it checks the data, it does not fit the model to them.
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np
import scipy.io

DATA = Path(__file__).resolve().parents[2] / "shared" / "data" / "grand-challenge-knee-jw" / "reducepoly_subject_GC"


def table(path: Path, key: str) -> tuple[np.ndarray, list[str]]:
    m = scipy.io.loadmat(path, squeeze_me=True, struct_as_record=False)[key]
    return np.asarray(m.data, float), [str(c) for c in m.colheaders]


def best_lag(t: np.ndarray, y: np.ndarray, t_other: np.ndarray, y_other: np.ndarray) -> tuple[float, float, float]:
    """(lag s, correlation at it, correlation at lag 0) of ``y(t)`` against ``y_other(t + lag)``."""
    def corr(lag: float) -> float:
        inside = (t + lag >= t_other[0]) & (t + lag <= t_other[-1])
        return float(np.corrcoef(y[inside], np.interp(t[inside] + lag, t_other, y_other))[0, 1])

    lags = np.round(np.arange(-0.2, 0.2001, 0.001), 3)
    r = np.array([corr(lag) for lag in lags])
    k = int(np.argmax(np.abs(r)))
    return float(lags[k]), float(r[k]), corr(0.0)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", type=Path, default=DATA)
    ap.add_argument("--trial", default="ngait_og5")
    a = ap.parse_args(argv)
    K, kc = table(a.data / "KCF" / f"KCF_{a.trial}.mat", "dataKCF")
    G, gc = table(a.data / "GRF" / f"GRF_{a.trial}.mat", "GRFall")
    Q, qc = table(a.data / "IK" / f"IK_{a.trial}.mat", "Qsall")
    print(f"| {a.trial}: KCF channel | against | lag of the best correlation (s) | correlation there | at lag 0 |")
    print("|---|---|---|---|---|")
    plates = sorted({c.split("_")[0] for c in gc if c.startswith("grforce")})
    for plate in plates:
        lag, r, r0 = best_lag(K[:, 0], K[:, kc.index("GRFz")], G[:, 0], G[:, gc.index(f"{plate}_fy")])
        print(f"| GRFz | GRF {plate}_fy | {lag:+.3f} | {r:.4f} | {r0:.4f} |")
    lag, r, r0 = best_lag(K[:, 0], K[:, kc.index("GON")], Q[:, 0], -Q[:, qc.index("knee_flexion")])
    print(f"| GON | minus IK knee_flexion | {lag:+.3f} | {r:.4f} | {r0:.4f} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
