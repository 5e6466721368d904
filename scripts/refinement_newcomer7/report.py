"""Tables of results.jsonl (python report.py [FILE]), markdown to stdout: newcomer 6's report
(``scripts/refinement_newcomer6/report.py``) on this folder, with the section titles of ``models.REPORT_NAMES``."""
import os
import runpy
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
os.environ["NEWCOMER_DIR"] = HERE
REPORT = os.path.join(HERE, "..", "refinement_newcomer6", "report.py")
sys.argv[0] = REPORT
runpy.run_path(REPORT, run_name="__main__")
