"""The pendulum's junction times with the input's continuity imposed at both junctions (a necessary condition; the
phase reference's J is flat in them, ``junction_check.py``), against the free-junction reference, N = 40 and 80.

    python ref_continuity.py
"""
import nc8
from reference import Phases

for N in (40, 80):
    free = Phases(nc8.spec("pend"), N).solve()
    cont = Phases(nc8.spec("pend"), N).solve(continuity=True)
    print(f"N = {N}: free junctions {free.t1:.9f} {free.t2:.9f} J {free.J:.14f}; "
          f"continuous input {cont.t1:.9f} {cont.t2:.9f} J {cont.J:.14f}")
