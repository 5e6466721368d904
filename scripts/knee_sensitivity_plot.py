"""Plot a knee sensitivity batch: medial/lateral RMSE and peaks against condyle spacing and alignment.

    python scripts/knee_sensitivity_plot.py results/batch/knee_sensitivity

reads ``DIR/batch.csv`` (one row per run of ``examples/batch_knee_sensitivity.toml``): the
condyle spacing of a run from its ``--param medial_cz=...``/``lateral_cz=...`` arguments (the
implant's own where none is given), its frontal-plane alignment from the ``knee_adduction``
column of its motion file (degrees of varus), its RMSE from the table's
``comparison.<side>.rmse_bw`` columns and its predicted and measured peaks from the run's
``summary.json``. Writes ``DIR/knee_sensitivity.png`` (four panels, one line per alignment)
and ``DIR/knee_sensitivity.md`` (the same numbers as a table), and prints the table.
"""
from __future__ import annotations

import csv
import json
import os
import shlex
import sys
from pathlib import Path

os.environ.setdefault("MPLBACKEND", "Agg")

SIDES = ("medial", "lateral")


def _geometry() -> dict[str, float]:
    from ocp_constraints.biomech.knee_contact import stored_geometry

    return stored_geometry()


def _params(args: list[str]) -> dict[str, float]:
    out = {}
    for a, b in zip(args, args[1:]):
        if a == "--param" and "=" in b:
            k, v = b.split("=", 1)
            out[k] = float(v)
    return out


def _option(args: list[str], name: str) -> str:
    return args[args.index(name) + 1]


def _varus_deg(motion: Path) -> float:
    with open(motion, newline="") as fh:
        reader = csv.DictReader(fh)
        return float(next(reader)["knee_adduction"])


def collect(folder: Path) -> list[dict]:
    """One record per succeeded run: spacing (mm), varus (deg), RMSE and peaks (BW) per side."""
    geometry = _geometry()
    records = []
    with open(folder / "batch.csv", newline="") as fh:
        for row in csv.DictReader(fh):
            if row["status"] not in ("succeeded", "skipped"):
                continue
            args = shlex.split(row["args"])
            summary = json.loads((folder / "runs" / row["id"] / "summary.json").read_text())
            motion = Path(_option(args, "--motion"))     # absolute: a { glob } value
            p = {**geometry, **_params(args)}
            rec = {"spacing_mm": 1e3 * (p["medial_cz"] - p["lateral_cz"]), "varus_deg": _varus_deg(motion)}
            for side in SIDES:
                c = summary["comparison"][side]
                rec[f"{side}_rmse_bw"] = float(row[f"comparison.{side}.rmse_bw"])
                rec[f"{side}_peak_bw"] = c["peak_predicted_bw"]
                rec[f"{side}_peak_measured_bw"] = c["peak_measured_bw"]
            records.append(rec)
    return sorted(records, key=lambda r: (r["varus_deg"], r["spacing_mm"]))


def table(records: list[dict]) -> str:
    lines = ["| varus (deg) | condyle spacing (mm) | medial RMSE (BW) | lateral RMSE (BW) | medial peak (BW) | "
             "lateral peak (BW) |", "|---:|---:|---:|---:|---:|---:|"]
    for r in records:
        lines.append(f"| {r['varus_deg']:+g} | {r['spacing_mm']:.1f} | {r['medial_rmse_bw']:.3f} | "
                     f"{r['lateral_rmse_bw']:.3f} | {r['medial_peak_bw']:.2f} | {r['lateral_peak_bw']:.2f} |")
    if records:
        lines.append(f"\nMeasured peaks: medial {records[0]['medial_peak_measured_bw']:.2f} BW, "
                     f"lateral {records[0]['lateral_peak_measured_bw']:.2f} BW.")
    return "\n".join(lines)


def plot(records: list[dict], path: Path) -> None:
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(2, 2, figsize=(9, 6.5), sharex=True)
    for varus in sorted({r["varus_deg"] for r in records}):
        rs = [r for r in records if r["varus_deg"] == varus]
        x = [r["spacing_mm"] for r in rs]
        label = f"{varus:g} deg varus" if varus > 0 else f"{-varus:g} deg valgus" if varus < 0 else "as measured"
        for j, side in enumerate(SIDES):
            axes[0, j].plot(x, [r[f"{side}_rmse_bw"] for r in rs], "o-", label=label)
            axes[1, j].plot(x, [r[f"{side}_peak_bw"] for r in rs], "o-", label=label)
    for j, side in enumerate(SIDES):
        axes[0, j].set_title(f"{side}: RMSE against eTibia")
        axes[1, j].set_title(f"{side}: peak contact force")
        axes[0, j].set_ylabel("RMSE (BW)")
        axes[1, j].set_ylabel("peak (BW)")
        axes[1, j].axhline(records[0][f"{side}_peak_measured_bw"], color="k", ls="--", lw=1, label="measured peak")
        axes[1, j].set_xlabel("condyle spacing medial_cz - lateral_cz (mm)")
    axes[0, 0].legend(fontsize=8)
    axes[1, 0].legend(fontsize=8)
    fig.suptitle("Knee contact loads, JW ngait_og5: sensitivity to condyle spacing and frontal alignment")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def main(folder: str) -> int:
    folder = Path(folder)
    records = collect(folder)
    if not records:
        print(f"{folder}/batch.csv has no succeeded knee runs", file=sys.stderr)
        return 1
    text = table(records)
    (folder / "knee_sensitivity.md").write_text(text + "\n")
    plot(records, folder / "knee_sensitivity.png")
    print(text)
    print(f"\nwrote {folder / 'knee_sensitivity.png'} and {folder / 'knee_sensitivity.md'}")
    return 0


if __name__ == "__main__":
    if len(sys.argv) != 2:
        raise SystemExit(__doc__)
    raise SystemExit(main(sys.argv[1]))
