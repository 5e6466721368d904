"""``report.html``: one self-contained page per run (summary, plots, the head of every table).

Open it in any browser, from a disk, a mail attachment or a web server: the PNG plots are
embedded (base64 ``<img>``), the style is inline, there is no script and nothing is fetched.
Sections: the status (success or not, the message), the key results, ``summary.json`` as a
folded table (nested entries by their path, long lists shortened), the plots, the first rows of every CSV, and
links to the run's files (relative, so they work beside the page).
"""
from __future__ import annotations

import base64
import html
import json
from pathlib import Path

from .files import write_atomic

HEAD_ROWS = 10
#: Entries of summary.json shown first (by path prefix); the whole summary follows, folded.
KEY = ("scene", "task", "model", "method", "samples", "frames", "t_reached", "t_final", "objective", "iterations",
       "wall_time.total", "wall_time_s.total", "max_constraint_residual", "energy.relative_error", "joint_work",
       "max_equation_residual", "peak_bw", "comparison", "reintegration")
STYLE = """
body{font-family:system-ui,-apple-system,Segoe UI,Helvetica,Arial,sans-serif;margin:2em auto;max-width:1100px;
     color:#1d2329;padding:0 1em}
h1{font-size:1.6em;margin-bottom:.2em} h2{border-bottom:1px solid #d0d7de;padding-bottom:.2em;margin-top:1.6em}
.status{display:inline-block;padding:.25em .7em;border-radius:1em;font-weight:600}
.ok{background:#dafbe1;color:#116329} .fail{background:#ffebe9;color:#a40e26}
table{border-collapse:collapse;font-size:.85em} td,th{border:1px solid #d0d7de;padding:.25em .5em;text-align:left;
     vertical-align:top} th{background:#f6f8fa} td.num{text-align:right;font-variant-numeric:tabular-nums;white-space:nowrap}
.scroll{overflow-x:auto;max-width:100%;margin-bottom:1em} figure{margin:1em 0} img{max-width:100%;width:880px;
     border:1px solid #d0d7de} figcaption{font-size:.85em;color:#57606a} code{background:#f6f8fa;padding:0 .2em}
"""


def _flatten(value, prefix: str = "") -> list[tuple[str, str]]:
    """``(path, text)`` rows of a nested summary; long lists shortened."""
    if isinstance(value, dict):
        rows = []
        for k, v in value.items():
            rows += _flatten(v, f"{prefix}.{k}" if prefix else str(k))
        return rows or [(prefix, "{}")]
    if isinstance(value, (list, tuple)) and value and all(not isinstance(v, (dict, list)) for v in value):
        shown = ", ".join(_text(v) for v in value[:12])
        more = f" ... ({len(value) - 12} more)" if len(value) > 12 else ""
        return [(prefix, f"[{shown}{more}]")]
    if isinstance(value, (list, tuple)):
        return [(prefix, json.dumps(value, default=str)[:400])]
    return [(prefix, _text(value))]


def _text(v) -> str:
    if isinstance(v, float):
        return f"{v:.6g}"
    return "null" if v is None else str(v)


def _rows(rows: list[tuple[str, str]]) -> str:
    return "".join(f"<tr><th>{html.escape(k)}</th><td>{html.escape(v)}</td></tr>" for k, v in rows)


def _csv_head(path: Path, rows: int = HEAD_ROWS) -> str:
    with open(path) as fh:
        lines = [next(fh, "") for _ in range(rows + 1)]
    lines = [s.rstrip("\n") for s in lines if s]
    if not lines:
        return "<p>(empty)</p>"
    head = "".join(f"<th>{html.escape(c)}</th>" for c in lines[0].split(","))
    body = "".join("<tr>" + "".join(f'<td class="num">{_number(c)}</td>' for c in line.split(",")) + "</tr>"
                   for line in lines[1:])
    return f'<div class="scroll"><table><tr>{head}</tr>{body}</table></div>'


def _number(cell: str) -> str:
    try:
        return f"{float(cell):.6g}"
    except ValueError:
        return html.escape(cell)


def report_html(folder: Path, summary: dict, title: str | None = None, plots: list[str] | None = None,
                tables: list[str] | None = None) -> str:
    """The page's HTML for the run in ``folder`` (its PNG and CSV files are read from there)."""
    folder = Path(folder)
    plots = [p for p in (plots if plots is not None else sorted(x.name for x in folder.glob("*.png")))
             if (folder / p).is_file()]
    tables = [c for c in (tables if tables is not None else sorted(x.name for x in folder.glob("*.csv")))
              if (folder / c).is_file()]
    name = title or " / ".join(str(summary[k]) for k in ("scene", "task") if summary.get(k)) or "ocp_constraints run"
    ok = bool(summary.get("success", True))
    parts = [f"<!DOCTYPE html><html lang='en'><head><meta charset='utf-8'><title>{html.escape(name)}</title>"
             f"<meta name='viewport' content='width=device-width, initial-scale=1'><style>{STYLE}</style></head><body>",
             f"<h1>{html.escape(name)}</h1>",
             f"<p><span class='status {'ok' if ok else 'fail'}'>{'success' if ok else 'not successful'}</span> "
             f"{html.escape(str(summary.get('status', '')))}</p>"]
    if summary.get("message"):
        parts.append(f"<p>{html.escape(str(summary['message']))}</p>")
    flat = [(k, v) for k, v in _flatten(summary) if k not in ("plots", "report")]
    key = [(k, v) for k, v in flat if any(k == p or k.startswith(p + ".") for p in KEY)]
    parts.append(f"<h2>Key results</h2><div class='scroll'><table>{_rows(key)}</table></div>")
    parts.append(f"<details><summary>all of summary.json ({len(flat)} entries)</summary>"
                 f"<div class='scroll'><table>{_rows(flat)}</table></div></details>")
    if plots:
        parts.append("<h2>Plots</h2>")
        for p in plots:
            data = base64.b64encode((folder / p).read_bytes()).decode()
            parts.append(f"<figure><img alt='{html.escape(p)}' src='data:image/png;base64,{data}'>"
                         f"<figcaption>{html.escape(p)}</figcaption></figure>")
    for c in tables:
        parts.append(f"<h2>{html.escape(c)} (first {HEAD_ROWS} rows)</h2>{_csv_head(folder / c)}")
    files = sorted(x.name for x in folder.iterdir() if x.is_file() and not x.name.startswith("."))
    links = "".join(f"<li><a href='{html.escape(f)}'>{html.escape(f)}</a></li>" for f in files if f != "report.html")
    parts.append(f"<h2>Files</h2><ul>{links}</ul></body></html>")
    return "\n".join(parts)


def write_report(folder: Path, summary: dict, title: str | None = None, plots: list[str] | None = None,
                 tables: list[str] | None = None) -> str:
    """Write ``folder/report.html`` (see module docs); returns its name."""
    write_atomic(Path(folder) / "report.html", report_html(folder, summary, title, plots, tables).encode())
    return "report.html"
