"""Shared table writing for the benchmark runners.

One place for how a benchmark reports: numbers formatted as the paper prints
them, the paper's value beside ours, explicit denominators (``"3/3 valid"``),
greyed distortion of maps that still flip, the machine the run used, a JSONL
log of finished rows for ``--resume``, CSV + Markdown output, the paper-claim verdicts as data (``*.findings.json``)
and progress bars.
"""
from __future__ import annotations

import datetime as _dt
import json
import math
import os
import platform
import re
import shlex
import subprocess
import sys
from dataclasses import dataclass, field
from pathlib import Path

from neuraluv import plot
from neuraluv.io import atomic_write, jsonable, write_csv
from neuraluv.solver import resolve_device

__all__ = [
    "fmt_num", "fmt_pct", "fmt_time", "grey", "bold", "with_paper", "fraction", "GREY_NOTE", "PAPER_NOTE",
    "machine_info", "machine_line", "git_commit", "command_line", "markdown_table", "write_csv",
    "findings_markdown", "write_findings", "VERDICTS", "write_markdown", "RowLog", "start_run", "print_report", "progress", "BenchOutput", "is_num", "finite", "save_figure", "plain",
]

#: Footnote explaining the grey marker.
GREY_NOTE = ("† greyed: distortion of a map that still contains flipped triangles; as in the paper, "
             "it is not a meaningful comparison (E_SD of a flipped map is finite but arbitrary).")
#: Footnote explaining the bracketed paper values.
PAPER_NOTE = "Values in brackets [..] are the paper's published numbers for the same cell (— : the paper prints a dash)."


def is_num(x):
    """True for a real number that is not None/bool (nan and inf count)."""
    return isinstance(x, (int, float)) and not isinstance(x, bool) or type(x).__module__ == "numpy"


def finite(x):
    """True for a finite real number."""
    try:
        return x is not None and not isinstance(x, str) and math.isfinite(float(x))
    except (TypeError, ValueError):
        return False


def fmt_num(x, digits=2):
    """A number as the paper prints it: 2 decimals, ``1.47×10^9`` when large.

    Examples
    --------
    >>> fmt_num(4.1372), fmt_num(1.47e9), fmt_num(30909.1), fmt_num(float("nan")), fmt_num(None)
    ('4.14', '1.47×10^9', '30909.10', '—', '—')
    >>> fmt_num(float("inf")), fmt_num(-11.784), fmt_num("inf")   # "inf": a non-finite number read back from JSON
    ('∞', '-11.78', '∞')
    """
    if isinstance(x, str) and x in ("inf", "-inf", "nan"):
        x = float(x)
    if x is None or isinstance(x, str):
        return "—" if x is None else x
    x = float(x)
    if math.isnan(x):
        return "—"
    if math.isinf(x):
        return "∞" if x > 0 else "-∞"
    if abs(x) >= 1e5:
        e = int(math.floor(math.log10(abs(x))))
        m = x / 10**e
        if round(m, digits) >= 10:
            m, e = m / 10, e + 1
        return f"{m:.{digits}f}×10^{e}"
    if x != 0 and abs(x) < 10 ** (-digits):
        return f"{x:.{digits}g}" if abs(x) >= 1e-4 else f"{x:.1e}"
    return f"{x:.{digits}f}"


def fmt_pct(x, digits=2):
    """A percentage: ``13.56%`` (``—`` when missing).

    Examples
    --------
    >>> fmt_pct(13.5612), fmt_pct(0), fmt_pct(0.0097), fmt_pct(None)
    ('13.56%', '0.00%', '0.0097%', '—')
    """
    if not finite(x):
        return "—"
    x = float(x)
    if 0 < abs(x) < 10 ** (-digits):
        return f"{x:.2g}%"
    return f"{x:.{digits}f}%"


def fmt_time(x):
    """Seconds with 3 significant decimals below 10 s, 2 above.

    Examples
    --------
    >>> fmt_time(0.0012), fmt_time(23.441), fmt_time(None)
    ('0.001', '23.44', '—')
    """
    if not finite(x):
        return "—"
    x = float(x)
    return f"{x:.3f}" if x < 10 else f"{x:.2f}"


def grey(text):
    """Mark a value as greyed (Markdown: a grey HTML span plus a † that survives sanitising).

    Examples
    --------
    >>> grey("4.10")
    '<span style="color:gray">4.10†</span>'
    """
    return f'<span style="color:gray">{text}†</span>'


def bold(text):
    """Markdown bold."""
    return f"**{text}**"


def with_paper(ours, paper):
    """Our formatted value with the paper's beside it: ``"4.21 [4.14]"``.

    ``paper`` is a formatted string, or ``None`` when the paper has no such cell.

    Examples
    --------
    >>> with_paper("4.21", "4.14"), with_paper("4.21", None)
    ('4.21 [4.14]', '4.21')
    """
    return ours if paper is None else f"{ours} [{paper}]"


def fraction(n, N, what="", pct=False):
    """An explicit denominator: ``"3/3 valid"``, ``"42/47 (89.4%)"``.

    Examples
    --------
    >>> fraction(3, 3, "valid"), fraction(42, 47, pct=True), fraction(0, 0, pct=True)
    ('3/3 valid', '42/47 (89.4%)', '0/0')
    """
    s = f"{int(n)}/{int(N)}"
    if pct and N:
        s += f" ({100.0 * n / N:.1f}%)"
    return f"{s} {what}".rstrip()


# ------------------------------------------------------------------ provenance

def git_commit():
    """Short commit of the source tree (``+dirty`` with local changes to ``neuraluv/``), or ``"unknown"``.

    Examples
    --------
    >>> c = git_commit(); c == "unknown" or len(c.split("+")[0]) >= 7
    True
    """
    root = Path(__file__).resolve().parents[2]  # the checkout: neuraluv/bench/provenance.py -> ../../..
    try:
        sha = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=root, capture_output=True, text=True,
                             timeout=10).stdout.strip()
        if not sha:
            return "unknown"
        dirty = subprocess.run(["git", "status", "--porcelain", "--untracked-files=no", "--", "neuraluv"], cwd=root,
                               capture_output=True, text=True, timeout=10).stdout.strip()
        return sha + ("+dirty" if dirty else "")
    except (OSError, subprocess.SubprocessError):
        return "unknown"


def _cpu_model():
    try:
        with open("/proc/cpuinfo") as fh:
            for line in fh:
                if line.lower().startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine()


def _load_average():
    try:
        return round(os.getloadavg()[0], 1)
    except (OSError, AttributeError):
        return None


def machine_info(device="auto"):
    """Where a benchmark ran: platform, CPU, cores, torch, device, date, commit.

    Examples
    --------
    >>> sorted(machine_info("cpu"))
    ['commit', 'cores', 'cpu', 'date', 'device', 'load', 'platform', 'python', 'threads', 'torch']
    """
    import torch


    dev = resolve_device(device)
    dev_s = str(dev)
    if dev.type == "cuda":
        dev_s += f" ({torch.cuda.get_device_name(dev)})"
    return {
        "platform": platform.platform(),
        "cpu": _cpu_model(),
        "cores": os.cpu_count(),
        "threads": torch.get_num_threads(),
        "python": platform.python_version(),
        "torch": torch.__version__,
        "device": dev_s,
        "date": _dt.datetime.now(_dt.timezone.utc).strftime("%Y-%m-%d %H:%M UTC"),
        "commit": git_commit(),
        "load": _load_average(),
    }


def machine_line(info=None, device="auto"):
    """One line describing the machine, printed under every table."""
    m = info or machine_info(device)
    load = m.get("load")
    busy = ""
    if load is not None and m.get("cores") and load > m["cores"]:
        busy = f" (shared: 1-min load average {load} on {m['cores']} cores at the start, so wall times are inflated)"
    return (f"Machine: {m['platform']}; CPU {m['cpu']} ({m['cores']} cores{busy}, torch threads {m['threads']}); "
            f"Python {m['python']}, torch {m['torch']}; device {m['device']}; {m['date']}; commit {m['commit']}.")


def command_line(name, args=None):
    """The command that reproduces a run (``neuraluv bench NAME ...``)."""
    if args is not None and getattr(args, "_argv", None):
        return "neuraluv " + " ".join(shlex.quote(a) for a in args._argv)
    argv = sys.argv[1:]
    prog = sys.argv[0] if sys.argv else ""
    via_cli = os.path.basename(prog).startswith("neuraluv") or (
        os.path.basename(prog) == "__main__.py" and os.path.basename(os.path.dirname(prog)) == "neuraluv")
    if "bench" in argv and via_cli:  # `neuraluv bench ...` or `python -m neuraluv bench ...`
        return "neuraluv " + " ".join(shlex.quote(a) for a in argv)
    if args is None:
        return f"neuraluv bench {name} (Python API)"
    parts = [f"neuraluv bench {name}"]
    for key in ("output", "preset", "meshes", "quick", "resume", "seed"):
        v = getattr(args, key, None)
        if v in (None, False) or (key == "seed" and v == 0):
            continue
        if v is True:
            parts.append(f"--{key}")
        elif isinstance(v, (list, tuple)):
            parts.append(f"--{key} " + " ".join(map(str, v)))
        else:
            parts.append(f"--{key} {shlex.quote(str(v))}" if key != "output" else f"-o {shlex.quote(str(v))}")
    return " ".join(parts) + " (Python API)"


# ------------------------------------------------------------------ output

def markdown_table(header, rows, align=None):
    """A GitHub Markdown table.

    Parameters
    ----------
    header : list of str
    rows : list of list of str
    align : str, optional
        One character per column: ``l``, ``r`` or ``c`` (default: first
        column left, the rest right).

    Examples
    --------
    >>> print(markdown_table(["a", "b"], [["x", "1"]]))
    | a | b |
    |:--|--:|
    | x | 1 |
    """
    align = align or ("l" + "r" * (len(header) - 1))
    sep = {"l": ":--", "r": "--:", "c": ":-:"}
    lines = ["| " + " | ".join(header) + " |", "|" + "|".join(sep[a] for a in align) + "|"]
    for r in rows:
        lines.append("| " + " | ".join(str(c).replace("|", "\\|") for c in r) + " |")
    return "\n".join(lines)


def write_markdown(path, title, body, *, command, machine, notes=(), findings=None):
    """Write a Markdown report: title, how it was produced, the body, notes, the machine.

    With ``findings`` (the list whose :func:`findings_markdown` block the body shows), they are
    also written as data beside the report (:func:`write_findings`).
    """
    text = [f"# {title}", "", f"Produced by `{command}` on {machine['date']}.", "", body.rstrip(), ""]
    for n in notes:
        text += [n, ""]
    text += [machine_line(machine), ""]
    with atomic_write(path) as fh:
        fh.write("\n".join(text))
    if findings:
        write_findings(path, findings)
    return Path(path)


#: A finding's ``holds`` (True / False / None) as the verdict written in reports and findings files.
VERDICTS = {True: "holds", False: "does not hold here", None: "not tested"}


def write_findings(report, findings):
    """Write the paper-claim verdicts of a report as data: ``<report>.findings.json`` beside it.

    Parameters
    ----------
    report : path of the Markdown report (``results/<runner>/<table>.md``)
    findings : list of ``(claim, holds, detail)``, ``holds`` True / False / None (not tested)

    Returns
    -------
    Path of the JSON file (read by :func:`neuraluv_paper.claims.findings`).

    Examples
    --------
    >>> import tempfile, json; d = Path(tempfile.mkdtemp())
    >>> p = write_findings(d / "table9.md", [("A beats B", True, "3 vs 4")])
    >>> p.name, json.loads(p.read_text())["findings"][0]["verdict"]
    ('table9.findings.json', 'holds')
    """
    report = Path(report)
    data = {"report": report.name,
            "findings": [{"claim": c, "verdict": VERDICTS[h], "detail": d} for c, h, d in findings]}
    path = report.with_suffix(".findings.json")
    with atomic_write(path) as fh:
        fh.write(json.dumps(data, indent=1, ensure_ascii=False) + "\n")
    return path


class RowLog:
    """A JSONL log of finished rows, keyed by ``(mesh, method, config)``.

    With ``resume=False`` the log is emptied; with ``resume=True`` rows
    already in it are kept and :meth:`done` tells the runner to skip them —
    except rows whose ``status`` is in :attr:`REDO` (``"unavailable"``: an
    optional binary or module was missing then and may be installed now),
    which are recomputed and appended (the last line of a key wins).

    Examples
    --------
    >>> import tempfile; d = tempfile.mkdtemp()
    >>> log = RowLog(d + "/rows.jsonl"); _ = log.add(("camel", "lscm", {}), {"esd": 1.0}); log.done(("camel", "lscm", {}))
    True
    >>> RowLog(d + "/rows.jsonl", resume=True).get(("camel", "lscm", {}))["esd"]
    1.0
    >>> _ = RowLog(d + "/rows.jsonl", resume=True).add(("camel", "optcuts", {}), {"status": "unavailable"})
    >>> RowLog(d + "/rows.jsonl", resume=True).done(("camel", "optcuts", {}))
    False
    >>> RowLog(d + "/rows.jsonl", resume=False).done(("camel", "lscm", {}))
    False
    """

    #: Logged statuses that ``--resume`` recomputes instead of reusing.
    REDO = ("unavailable",)

    def __init__(self, path, resume=False):
        self.path = Path(path)
        self.rows = {}
        self.skipped = 0
        self.path.parent.mkdir(parents=True, exist_ok=True)
        if resume and self.path.exists():
            with open(self.path) as fh:
                for line in fh:
                    line = line.strip()
                    if not line:
                        continue
                    try:
                        rec = json.loads(line)
                    except json.JSONDecodeError:  # a line cut short by an interruption
                        continue
                    self.rows[rec["key"]] = rec["row"]
        else:
            self.path.write_text("")

    @staticmethod
    def key(key):
        mesh, method, config = key
        return json.dumps([str(mesh), str(method), config], sort_keys=True, default=str)

    def done(self, key):
        row = self.rows.get(self.key(key))
        return row is not None and not (isinstance(row, dict) and row.get("status") in self.REDO)

    def get(self, key):
        return self.rows.get(self.key(key))

    def add(self, key, row):
        row = jsonable(row)
        k = self.key(key)
        self.rows[k] = row
        with open(self.path, "a") as fh:
            fh.write(json.dumps({"key": k, "row": row}) + "\n")
            fh.flush()
        return row

    def run(self, key, fn):
        """``get(key)`` when finished (counted in :attr:`skipped`), else ``add(key, fn())``."""
        if self.done(key):
            self.skipped += 1
            return self.get(key)
        return self.add(key, fn())


def start_run(output, *, resume=False, device="auto"):
    """The start every table runner shares: its output folder (created), the machine, the resumable row log.

    Returns
    -------
    out : Path
    machine : dict (:func:`machine_info`)
    log : :class:`RowLog` of ``out / "rows.jsonl"`` (emptied unless ``resume``)
    """
    out = Path(output)
    out.mkdir(parents=True, exist_ok=True)
    return out, machine_info(device), RowLog(out / "rows.jsonl", resume=resume)


def print_report(*results):
    """The end every runner shares: each :class:`BenchOutput`'s report as plain text and the files it wrote.

    Returns
    -------
    int, the exit status 0
    """
    for res in results:
        print(plain(res.markdown))
        print("wrote " + ", ".join(str(p) for p in res.files))
    return 0


def progress(iterable, *, total=None, desc=None, disable=False):
    """A tqdm progress bar (to stderr) over ``iterable``."""
    from tqdm.auto import tqdm

    return tqdm(iterable, total=total, desc=desc, disable=disable, dynamic_ncols=True, leave=False)


@dataclass
class BenchOutput:
    """What a runner returns to Python callers (notebooks, tests).

    Attributes
    ----------
    name : benchmark name.
    rows : list of dict, the raw rows (also in the CSV).
    markdown : the Markdown report's text.
    files : written paths.
    findings : list of (claim, holds: bool or None, detail) comparing the
        paper's qualitative statements with our data.
    skipped : rows taken from the resume log instead of being recomputed.
    extra : runner-specific objects (e.g. summary rows, per-chart results).
    """

    name: str
    rows: list
    markdown: str = ""
    files: list = field(default_factory=list)
    findings: list = field(default_factory=list)
    skipped: int = 0
    extra: dict = field(default_factory=dict)


def findings_markdown(findings):
    """The "paper claim → on our data" list."""
    if not findings:
        return ""
    out = ["## The paper's findings on our data", ""]
    for claim, holds, detail in findings:
        out.append(f"- {claim} — **{VERDICTS[holds]}**: {detail}")
    return "\n".join(out)


def plain(text):
    """Markdown for a terminal: grey spans reduced to their text (the † stays).

    Examples
    --------
    >>> plain(grey("4.10") + " [5]")
    '4.10† [5]'
    """
    return re.sub(r'<span style="color:gray">(.*?)</span>', r"\1", text)



def save_figure(fig, path, dpi=64):
    """Save a matplotlib figure as PNG atomically, close it, return the path (:func:`neuraluv.plot.save_figure` at the benchmarks' 64 dpi)."""
    return plot.save_figure(fig, path, dpi=dpi)
