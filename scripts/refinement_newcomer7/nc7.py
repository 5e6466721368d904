"""Newcomer check 7: solve(tolerance=TOL) of two problems (models.py) against the references of ref.py, run by
newcomer 6's harness (``scripts/refinement_newcomer6/nc6.py``, its docstring says what is measured) on this folder.

    python nc7.py run PROBLEM TOL        # one refined solve; its record as JSON on the last line
    python nc7.py all [PROBLEM ...]      # every tolerance, one subprocess at a time (CPU cap 120 s, wall 300 s),
                                         # appended to results.jsonl
PROBLEM: a name of models.VARIANTS (urdf_arm, load_arm), optionally with "@rDnN": refined from the mesh Radau D x N
(solve(oc.Radau(N, degree=D), tolerance=TOL)) instead of the default start (Radau 5 x 10); env REF: compare with
ref_REF.npz instead of ref_PROBLEM.npz.
"""
import os
import runpy
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
os.environ["NEWCOMER_DIR"] = HERE
HARNESS = os.path.join(HERE, "..", "refinement_newcomer6", "nc6.py")
sys.argv[0] = HARNESS
runpy.run_path(HARNESS, run_name="__main__")
