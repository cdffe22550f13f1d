"""The notebooks' one runtime switch: quick (CI) runs or paper-scale runs.

Every notebook in ``notebooks/`` runs in about a minute on a 2-core CPU by
default: the real compact charts (Camel, Hand, Bob; :func:`load_chart`) wherever
the lesson is a real failure, the real ``"fast"`` preset or short budgets, fixed
seeds; procedural charts only where a construction is the point, or as stand-ins
when the real meshes are not cached. Setting the environment variable
``NEURALUV_PAPER_SCALE=1`` before starting Jupyter (or ``make book``) switches
every notebook to the paper's settings (the ``"paper"`` preset, the compact real
charts). Notebooks choose between the two with :func:`budget`, and print the
committed reference points beside their own numbers with :func:`reference`
(e.g. SLIM-1k on the same chart).

The module also keeps the notebooks quiet (:func:`setup` routes VTK to an
off-screen EGL window when there is no display and imports tqdm without its
widget warning) and reads the *claims checklist*: every "paper's findings on
our data" block of the committed ``results/*/table*.md`` reports
(:func:`findings`), the rows a chapter touches (:func:`checklist`) and the
book's claim → notebook → evidence page (:func:`claims_page`).
"""
from __future__ import annotations

import ctypes.util
import os
import random
import re
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np

__all__ = ["ENV_VAR", "paper_scale", "budget", "setup", "mode", "load_chart", "reference", "quiet_environment",
           "PAPER_TABLES", "CHAPTER_CLAIMS", "Claim", "results_dir", "parse_findings", "report_files", "findings",
           "checklist", "claims_page"]

#: Name of the environment variable that selects paper-scale runs.
ENV_VAR = "NEURALUV_PAPER_SCALE"

_TRUE = {"1", "true", "yes", "on"}


def paper_scale(environ=None) -> bool:
    """True when ``NEURALUV_PAPER_SCALE`` is set to 1/true/yes/on.

    Parameters
    ----------
    environ : mapping, optional
        Where to read the variable (default ``os.environ``).

    Examples
    --------
    >>> paper_scale({"NEURALUV_PAPER_SCALE": "1"}), paper_scale({})
    (True, False)
    """
    env = os.environ if environ is None else environ
    return env.get(ENV_VAR, "").strip().lower() in _TRUE


def budget(quick, paper, *, scale=None):
    """Pick the quick or the paper-scale value of a setting.

    Parameters
    ----------
    quick : any
        Value for the default quick run (CI, about a minute per notebook).
    paper : any
        Value for ``NEURALUV_PAPER_SCALE=1``.
    scale : bool, optional
        Force a mode (default: :func:`paper_scale`).

    Examples
    --------
    >>> budget(200, 5000, scale=False), budget(200, 5000, scale=True)
    (200, 5000)
    """
    return paper if (paper_scale() if scale is None else scale) else quick


def mode() -> str:
    """A one-line description of the active mode, printed by :func:`setup`."""
    if paper_scale():
        return f"paper-scale run ({ENV_VAR}=1): expect minutes to hours on a CPU"
    return f"quick run (set {ENV_VAR}=1 for paper-scale settings)"


def setup(seed=0, threads="auto"):
    """Seed every random generator and set torch's CPU threads; returns the mode line.

    Parameters
    ----------
    seed : int
    threads : int, "auto" or None
        ``torch.set_num_threads`` value. ``"auto"``: one thread for quick runs
        (the tiny networks run fastest single-threaded, especially on a shared
        machine), torch's default at paper scale. None leaves it alone.

    Examples
    --------
    >>> setup(0, threads=None).startswith(("quick", "paper"))
    True
    """
    import torch

    quiet_environment()
    random.seed(seed)
    np.random.seed(seed)
    torch.manual_seed(seed)
    if threads == "auto":
        threads = None if paper_scale() else 1
    if threads:
        torch.set_num_threads(int(threads))
    return mode()


def quiet_environment(environ=None):
    """Silence the two stray stderr lines a notebook kernel would otherwise print.

    * VTK: without a display, pyvista's default X window prints "bad X server
      connection" on the first render. When no ``DISPLAY`` is set and libEGL is
      present, VTK is pointed at its EGL window (``VTK_DEFAULT_OPENGL_WINDOW``),
      which renders off screen without X; a user's own setting is kept.
    * tqdm: ``tqdm.auto`` warns "IProgress not found" once, on import, in a
      kernel without ipywidgets (pyvista imports it). It is imported here with
      that warning suppressed (it then falls back to the text bar).

    Parameters
    ----------
    environ : mutable mapping, optional
        Where to set the variables (default ``os.environ``).

    Returns
    -------
    dict
        The variables it set (empty when it changed nothing).

    Examples
    --------
    >>> quiet_environment({"DISPLAY": ":0", "PYVISTA_OFF_SCREEN": "true"})
    {}
    """
    env = os.environ if environ is None else environ
    changed = {}
    if "PYVISTA_OFF_SCREEN" not in env:
        changed["PYVISTA_OFF_SCREEN"] = "true"
    if not env.get("DISPLAY") and "VTK_DEFAULT_OPENGL_WINDOW" not in env and ctypes.util.find_library("EGL"):
        changed["VTK_DEFAULT_OPENGL_WINDOW"] = "vtkEGLRenderWindow"
    env.update(changed)
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", message=".*IProgress not found.*")
        try:
            import tqdm.auto  # noqa: F401  (cached: later imports do not warn again)
        except ImportError:
            pass
    return changed


def load_chart(quick="glove", paper="camel", **quick_kwargs):
    """Load the notebook's chart: ``quick`` by default, ``paper`` at paper scale.

    A real mesh that is not cached falls back to ``quick`` (and a missing real
    ``quick`` mesh to the procedural glove) with a printed note (fetch it with
    ``python data_scripts/fetch.py``), so a notebook always runs.

    Parameters
    ----------
    quick, paper : str
        Names accepted by :func:`neuraluv.datasets.load`.
    **quick_kwargs
        Size options for a procedural ``quick`` chart (e.g. ``n_rings=8``),
        passed to :func:`neuraluv.datasets.procedural`.

    Returns
    -------
    name : str
        The chart actually loaded.
    V : (n,3) float array
    F : (m,3) int array

    Examples
    --------
    >>> name, V, F = load_chart("disk", "camel", n_rings=2)
    >>> name, V.shape, F.shape
    ('disk', (19, 3), (24, 3))
    """
    from neuraluv import datasets

    def _quick():
        if quick_kwargs:
            return datasets.procedural(quick, **quick_kwargs)
        return datasets.load(quick)

    if paper_scale():
        try:
            return (paper, *datasets.load(paper))
        except datasets.DataMissing as err:
            if quick == paper:
                print(f"{err}: using the procedural 'glove' chart instead")
                return ("glove", *datasets.glove())
            print(f"{err}: using the {quick!r} chart instead")
    try:
        return (quick, *_quick())
    except datasets.DataMissing as err:
        print(f"{err}: using the procedural 'glove' chart instead")
        return ("glove", *datasets.glove())


def reference(mesh, method="slim-1k", root=None):
    """A committed Table 1 row: the reference point a notebook prints beside its own run.

    Reads ``results/compact/table2_compact.csv`` (``neuraluv bench compact
    --preset paper``; the paper's Table 1), so a notebook can set, e.g., SLIM-1k
    on the same chart beside its number without spending the 20–40 s SLIM-1k
    takes on Hand.

    Parameters
    ----------
    mesh : str
        ``"hand"``, ``"bob"`` or ``"camel"``.
    method : str
        The table's method name (``"slim-1k"``, ``"lscm"``, ``"bff"``,
        ``"neural"`` for our ``paper`` preset, ...).
    root : path, optional
        The ``results/`` folder (default :func:`results_dir`).

    Returns
    -------
    dict or None
        ``esd``, ``flips``, ``flip_percent``, ``min_det``, ``time`` (floats) and
        ``status``; None when the report or the row is missing (an installed
        package, or a procedural stand-in chart).

    Examples
    --------
    >>> reference("camel", root="/nonexistent") is None
    True
    >>> r = reference("camel")
    >>> r is None or (r["status"] == "ok" and r["flips"] == 0 and r["esd"] > 4)
    True
    """
    import csv

    path = (results_dir() if root is None else Path(root)) / "compact" / "table2_compact.csv"
    if not path.is_file():
        return None
    with open(path, newline="", encoding="utf-8") as fh:
        row = next((r for r in csv.DictReader(fh)
                    if (r["mesh"], r["mode"], r["method"]) == (mesh, "whole", method)), None)
    if row is None:
        return None
    num = {k: float(row[k]) if row[k] not in ("", "nan") else float("nan")
           for k in ("esd", "flips", "flip_percent", "min_det", "time")}
    return {**num, "status": row["status"]}


# ----------------------------------------------------------------- the claims checklist

#: The paper's tables in the LaTeX source's order (so ``number`` is the paper's
#: Table N), with where this package's evidence lives: ``results`` is the
#: committed report (``None``: nothing committed) and ``runner`` the
#: ``neuraluv bench`` command that writes it (``None``: no runner). The report
#: file names keep the project's older numbering (``table2_compact.md`` is the
#: paper's Table 1).
PAPER_TABLES = (
    dict(number=1, label="tab:compact_prelim", title="compact pre-cut charts",
         results="compact/table2_compact.md", runner="compact"),
    dict(number=2, label="tab:slim_failure_modes", title="compact baseline failure modes",
         results="failure-modes/table3_failure_modes.md", runner="failure-modes"),
    dict(number=3, label="tab:ablation_prelim", title="compact ablations",
         results="ablation/table4_ablation.md", runner="ablation"),
    dict(number=4, label="tab:ntk_compact_controls", title="NTK–LBO subspace alignment",
         results="ntk/table5.md", runner="ntk"),
    dict(number=5, label="tab:thingi_scale", title="Thingi10K / xatlas-cut charts",
         results="charts/table6_charts.md", runner="charts"),
    dict(number=6, label="tab:runtime_pareto", title="runtime–quality Pareto sweep (CUDA)",
         results="pareto/table7_pareto.md", runner="pareto"),
    dict(number=7, label="tab:amara_coverage_validity", title="Amara coverage and validity",
         results="generated/amara_coverage_validity.md", runner="generated"),
    dict(number=8, label="tab:amara_blender_methods", title="Blender chart-level baselines on Amara",
         results="generated/amara_blender_methods.md", runner="generated"),
    dict(number=9, label="tab:amara_large_sweep", title="larger Amara atlas runs (Rust implementation)",
         results="generated/amara_large_sweep.md", runner="generated"),
)

#: Which checklist rows each chapter touches: (report file, a substring of the
#: claim as the committed report words it) or the paper's table number for a
#: table without a committed report. ``"08"`` shows every row.
CHAPTER_CLAIMS = {
    "00": [("compact/table2_compact.md", "Camel: SLIM-1k is zero-flip and the better fixed-chart solver"),
           ("failure-modes/table3_failure_modes.md", "Camel / SLIM-1k")],
    "00b": [("compact/table2_compact.md", "only ours is foldover-free"),
            ("compact/table2_compact.md", "Camel: LSCM and ARAP still fold")],
    "01": [("ablation/table4_ablation.md", "Removing LBO features"),
           ("ntk/table5.md", "Spectral inputs raise S(16) at init"),
           ("ntk/table5.md", "Spectral inputs raise S(4) at init")],
    "02": [("ablation/table4_ablation.md", "Spectral init"),
           ("ablation/table4_ablation.md", "Random init")],
    "03": [("compact/table2_compact.md", "only ours is foldover-free"),
           ("compact/table2_compact.md", "Hand: LSCM, ARAP, SLIM-1k and BFF all fold")],
    "03b": [("compact/table2_compact.md", "only ours is foldover-free"),
            ("compact/table2_compact.md", "Hand: LSCM, ARAP, SLIM-1k and BFF all fold"),
            ("compact/table2_compact.md", "Camel: SLIM-1k is zero-flip and the better fixed-chart solver"),
            ("ablation/table4_ablation.md", "Spectral init"),
            ("ablation/table4_ablation.md", "Random init")],
    "03c": [("compact/table2_compact.md", "only ours is foldover-free"),
            ("ablation/table4_ablation.md", "Removing LBO features"),
            ("ablation/table4_ablation.md", "Spectral init"),
            ("ablation/table4_ablation.md", "Random init")],
    "04": [("compact/table2_compact.md", "only ours is foldover-free"),
           ("compact/table2_compact.md", "slower than LSCM"),
           ("charts/table6_charts.md", "stratified set is mostly valid"), ("pareto/table7_pareto.md", "")],
    "05": [("compact/table2_compact.md", "only ours is foldover-free"),
           ("compact/table2_compact.md", "Hand: LSCM, ARAP, SLIM-1k and BFF all fold"),
           ("compact/table2_compact.md", "Bob: "), ("compact/table2_compact.md", "Camel: "),
           ("failure-modes/table3_failure_modes.md", "")],
    "06": [("ntk/table5.md", ""), ("ablation/table4_ablation.md", "bandwidth rows")],
    "07": [("charts/table6_charts.md", "small-chart sweep is almost all valid"), ("generated/amara_coverage_validity.md", "")],
    "09": [("compact/table2_compact.md", "Camel: LSCM and ARAP still fold"),
           ("compact/table2_compact.md", "OptCuts resolves Hand and Camel")],
}

_FINDINGS_HEADINGS = ("## The paper's findings on our data", "## Does our data show the paper's effects?")
_VERDICTS = {"holds": "holds", "does not hold here": "does not hold here", "does not hold": "does not hold here",
             "not tested": "not tested", "yes": "holds", "no": "does not hold here"}


@dataclass(frozen=True)
class Claim:
    """One row of the claims checklist.

    ``source``: the report it was read from, relative to ``results/`` (None for
    a table without one); ``table``: the paper's table number (LaTeX order) or
    None; ``claim``: the paper's claim as the report words it; ``verdict``:
    ``holds`` / ``does not hold here`` / ``not tested`` / ``not run``;
    ``detail``: our numbers.
    """

    source: str | None
    table: int | None
    claim: str
    verdict: str
    detail: str


def results_dir():
    """The committed ``results/`` folder next to the package (``$NEURALUV_RESULTS`` overrides it)."""
    env = os.environ.get("NEURALUV_RESULTS")
    return Path(env) if env else Path(__file__).resolve().parents[1] / "results"


def _table_of(source):
    """The paper's table a results file regenerates: its own entry, or, for a subset run in a
    sub-folder (``ablation/paper-camel-1k/table4_ablation.md``), its folder's main table's.

    Examples
    --------
    >>> _table_of("ablation/table4_ablation.md")["label"], _table_of("ablation/seeds/table4_ablation.md")["label"]
    ('tab:ablation_prelim', 'tab:ablation_prelim')
    >>> _table_of("ablation/notes.md") is None
    True
    """
    parts = source.split("/")
    for t in PAPER_TABLES:
        if t["results"] in (source, "/".join(parts[:1] + parts[-1:])):
            return t
    return None


def parse_findings(text, source=None, table=None):
    """The claims of one report's findings block(s), parsed from its Markdown.

    Two formats are read: ``- claim — **holds**: detail`` (the table runners)
    and ``- **claim: YES.** detail`` (the NTK runner).

    Examples
    --------
    >>> md = '''# Table
    ... ## The paper's findings on our data
    ...
    ... - A beats B — **holds**: 3 vs 4
    ... - C folds — **does not hold here**: 0.00% flips
    ...
    ... Paper caption: ...
    ... ## Does our data show the paper's effects?
    ... - **k raises S(16): YES.** 0.5 -> 0.8
    ... - **S predicts flips: NOT TESTED.** no variance
    ... '''
    >>> [(c.claim, c.verdict, c.detail) for c in parse_findings(md)]  # doctest: +NORMALIZE_WHITESPACE
    [('A beats B', 'holds', '3 vs 4'), ('C folds', 'does not hold here', '0.00% flips'),
     ('k raises S(16)', 'holds', '0.5 -> 0.8'), ('S predicts flips', 'not tested', 'no variance')]
    """
    out, inside, items = [], False, []
    for line in text.splitlines():
        if line.startswith("#"):
            inside = line.strip() in _FINDINGS_HEADINGS
            continue
        if not inside:
            continue
        if line.startswith("- "):
            items.append(line[2:].strip())
        elif line.startswith("  ") and items:
            items[-1] += " " + line.strip()
        elif line.strip() and items:
            inside = False  # the list ended (caption, notes)
    for item in items:
        m = re.match(r"^(?P<claim>.+?)\s+—\s+\*\*(?P<v>[^*]+)\*\*:?\s*(?P<detail>.*)$", item)
        if m is None:
            m = re.match(r"^\*\*(?P<claim>.+?):\s*(?P<v>YES|NO|NOT TESTED)\.?\*\*\s*(?P<detail>.*)$", item)
        if m is None:
            continue
        verdict = _VERDICTS.get(m["v"].strip().lower(), m["v"].strip())
        out.append(Claim(source, table, m["claim"].strip(), verdict, m["detail"].strip()))
    return out


def report_files(root=None):
    """The committed reports that :func:`findings` reads: ``results/*/table*.md``, ``results/*/amara_*.md``
    and the subset runs ``results/*/*/table*.md`` (sorted paths; empty without a ``results/`` folder)."""
    root = results_dir() if root is None else Path(root)
    return sorted([*root.glob("*/table*.md"), *root.glob("*/amara_*.md"), *root.glob("*/*/table*.md")])


def findings(root=None):
    """Every claim of every committed ``results/*/table*.md`` (and ``amara_*.md``, and the subset runs in
    ``results/*/*/table*.md``) findings block, in the paper's table order.

    Returns
    -------
    list of Claim
        Empty when there is no ``results/`` folder (an installed package).
    """
    root = results_dir() if root is None else Path(root)
    out = []
    for path in report_files(root):
        source = path.relative_to(root).as_posix()
        t = _table_of(source)
        out += parse_findings(path.read_text(encoding="utf-8"), source, t["number"] if t else None)
    return sorted(out, key=lambda c: (c.table is None, c.table or 0))


def _not_run(number):
    t = next(t for t in PAPER_TABLES if t["number"] == number)
    if t["runner"] is None:
        why = "no runner in this package: the Amara Spatial assets (and the paper's Rust atlas code) are not available"
    else:
        why = f"no committed run; the runner is `neuraluv bench {t['runner']}`"
    return Claim(None, number, t["title"][0].upper() + t["title"][1:], "not run", why)


def _every_row(claims):
    rows = claims + [_not_run(t["number"]) for t in PAPER_TABLES if t["results"] is None]
    return sorted(rows, key=lambda c: (c.table is None, c.table or 0))


def _select(chapter, claims):
    rows = []
    for sel in CHAPTER_CLAIMS.get(chapter, []):
        if isinstance(sel, int):
            rows.append(_not_run(sel))
            continue
        source, text = sel
        rows += [c for c in claims if c.source == source and text in c.claim and c not in rows]
    return rows


def _cell(text):
    return str(text).replace("|", "\\|").replace("\n", " ")


def _table(rows, with_notebooks=False, claims=None):
    head = "| Paper | Claim | On our data | Evidence |"
    sep = "|:--|:--|:--|:--|"
    if with_notebooks:
        head, sep = head + " Notebooks |", sep + ":--|"
    lines = [head, sep]
    for c in rows:
        paper = f"Table {c.table}" if c.table else "—"
        evidence = f"`results/{c.source}`" if c.source else "—"
        verdict = f"**{c.verdict}**" + (f": {c.detail}" if c.detail else "")
        line = f"| {paper} | {_cell(c.claim)} | {_cell(verdict)} | {evidence} |"
        if with_notebooks:
            nbs = sorted({ch for ch in CHAPTER_CLAIMS if c in _select(ch, claims)} | {"08"})
            line += f" {', '.join(nbs)} |"
        lines.append(line)
    return "\n".join(lines)


def checklist(chapter, root=None):
    """The checklist rows a chapter touches, as a Markdown table read from the committed results.

    Parameters
    ----------
    chapter : str
        The notebook's number (``"01"``, ``"00b"``); ``"08"`` gives every row.
    root : path, optional
        The ``results/`` folder (default :func:`results_dir`).

    Returns
    -------
    str
        Markdown: one row per claim (paper table, claim, verdict and our numbers,
        evidence file), or a one-line note when there is nothing to show.

    Examples
    --------
    >>> checklist("99", root="/nonexistent").startswith("No committed")
    True
    """
    claims = findings(root)
    if chapter == "08":
        rows = _every_row(claims)
    else:
        rows = _select(chapter, claims)
    rows = [r for r in rows if r.source is None or claims]
    if not rows:
        return "No committed findings touch this chapter (no `results/` folder next to the package?)."
    return _table(rows)


def claims_page(root=None):
    """The book's claims page: every claim → the notebooks that touch it → its evidence file (Markdown)."""
    claims = findings(root)
    rows = _every_row(claims)
    lines = [
        "# Claims checklist",
        "",
        "<!-- generated by book/build.py from neuraluv.notebook.claims_page(); do not edit by hand -->",
        "",
        "Every qualitative claim of the paper that a benchmark runner tests is listed below with what our committed",
        "run found, the chapters that discuss it and the report it was read from. The rows are parsed from the",
        "\"paper's findings on our data\" blocks of `results/*/table*.md` (`neuraluv.notebook.findings()`), so this",
        "page, notebook 08 and the checklist at the end of every chapter cannot drift from the numbers. Tables are",
        "numbered as in the paper's LaTeX (the report file names keep the project's older numbering:",
        "`table2_compact.md` is the paper's Table 1).",
        "",
        "## Claim → notebooks → evidence",
        "",
        "Verdicts: **holds**; **does not hold here** (our data disagree; read the detail before quoting the paper's",
        "number); **not tested** (an optional tool is missing); **not run** (no committed run, or no runner at all).",
        "",
        _table(rows, with_notebooks=True, claims=claims),
        "",
        "## The paper's tables and where their evidence lives",
        "",
        "| Paper table | LaTeX label | Report | Runner |",
        "|:--|:--|:--|:--|",
    ]
    for t in PAPER_TABLES:
        rep = f"`results/{t['results']}`" if t["results"] else "—"
        run = f"`neuraluv bench {t['runner']}`" if t["runner"] else "none"
        lines.append(f"| Table {t['number']}: {t['title']} | `{t['label']}` | {rep} | {run} |")
    return "\n".join(lines) + "\n"
