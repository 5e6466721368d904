"""Export the rolling disk's constraint functions as C, compile them, check the round trip.

Run: python examples/export_to_c.py [OUT_DIR]
Same as: ocp-constraints export-c rolling_disk --out OUT_DIR
Then in OUT_DIR: `make` builds the shared library and the example program, and
rolling_disk_constraints.h documents every argument by name (q, u, lambda layouts).
"""
import sys
import tempfile
from pathlib import Path

from ocp_constraints import export_c

out = Path(sys.argv[1]) if len(sys.argv) > 1 else Path(tempfile.mkdtemp()) / "rolling_disk_c"
report = export_c("rolling_disk", out, verify=True, n_states=200)
for fn in report.functions:
    print(f"{fn.name}: inputs {', '.join(fn.inputs)}; {fn.n_operations} operations")
print(f"{report.code_bytes} bytes of C in {report.out_dir}")
print(f"round trip on {report.round_trip.n_states} random states: max relative error {report.round_trip.max_error:.1e}")
