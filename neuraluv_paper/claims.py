"""The claims checklist: what the paper claims, what our committed runs found, and where.

Every runner that tests a qualitative claim of the paper writes its verdicts as
data beside its report: ``results/<runner>/<table>.findings.json`` (written by
:func:`neuraluv_paper.bench.provenance.write_markdown`; the same list is the
report's "paper's findings on our data" block). This module reads those files —
never the Markdown — into :class:`Claim` rows: the rows a notebook chapter
touches (:func:`checklist`), every row (:func:`findings`), the book's claim →
notebook → evidence page (:func:`claims_page`), and single reference numbers a
notebook prints beside its own (:func:`reference`).
"""
from __future__ import annotations

import csv
import json
import os
import re
from dataclasses import dataclass
from pathlib import Path

__all__ = ["PAPER_TABLES", "CHAPTER_CLAIMS", "Claim", "results_dir", "report_files", "findings", "checklist",
           "claims_page", "reference", "results_index", "heading"]

#: The paper's tables in the LaTeX source's order (so ``number`` is the paper's
#: Table N), with where this package's evidence lives: ``results`` is the
#: committed report (``None``: nothing committed) and ``runner`` the
#: ``neuraluv bench`` command that writes it (``None``: no runner). A report's
#: file name is its table's LaTeX label (``compact_prelim.md`` is
#: ``tab:compact_prelim``, the paper's Table 1) and its heading says both.
PAPER_TABLES = (
    dict(number=1, label="tab:compact_prelim", title="compact pre-cut charts",
         results="compact/compact_prelim.md", runner="compact"),
    dict(number=2, label="tab:slim_failure_modes", title="compact baseline failure modes",
         results="failure-modes/slim_failure_modes.md", runner="failure-modes"),
    dict(number=3, label="tab:ablation_prelim", title="compact ablations",
         results="ablation/ablation_prelim.md", runner="ablation"),
    dict(number=4, label="tab:ntk_compact_controls", title="NTK–LBO subspace alignment",
         results="ntk/ntk_compact_controls.md", runner="ntk"),
    dict(number=5, label="tab:thingi_scale", title="Thingi10K / xatlas-cut charts",
         results="charts/thingi_scale.md", runner="charts"),
    dict(number=6, label="tab:runtime_pareto", title="runtime–quality Pareto sweep (CUDA)",
         results="pareto/runtime_pareto.md", runner="pareto"),
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
    "00": [("compact/compact_prelim.md", "Camel: SLIM-1k is zero-flip and the better fixed-chart solver"),
           ("failure-modes/slim_failure_modes.md", "Camel / SLIM-1k")],
    "00b": [("compact/compact_prelim.md", "only ours is foldover-free"),
            ("compact/compact_prelim.md", "Camel: LSCM and ARAP still fold")],
    "01": [("ablation/ablation_prelim.md", "Removing LBO features"),
           ("ntk/ntk_compact_controls.md", "Spectral inputs raise S(16) at init"),
           ("ntk/ntk_compact_controls.md", "Spectral inputs raise S(4) at init")],
    "02": [("ablation/ablation_prelim.md", "Spectral init"),
           ("ablation/ablation_prelim.md", "Random init")],
    "03": [("compact/compact_prelim.md", "only ours is foldover-free"),
           ("compact/compact_prelim.md", "Hand: LSCM, ARAP, SLIM-1k and BFF all fold")],
    "03b": [("compact/compact_prelim.md", "only ours is foldover-free"),
            ("compact/compact_prelim.md", "Hand: LSCM, ARAP, SLIM-1k and BFF all fold"),
            ("compact/compact_prelim.md", "Camel: SLIM-1k is zero-flip and the better fixed-chart solver"),
            ("ablation/ablation_prelim.md", "Spectral init"),
            ("ablation/ablation_prelim.md", "Random init")],
    "03c": [("compact/compact_prelim.md", "only ours is foldover-free"),
            ("ablation/ablation_prelim.md", "Removing LBO features"),
            ("ablation/ablation_prelim.md", "Spectral init"),
            ("ablation/ablation_prelim.md", "Random init")],
    "03d": [("ablation/ablation_prelim.md", "The network adds over free per-vertex UVs"),
            ("compact/compact_prelim.md", "only ours is foldover-free")],
    "04": [("compact/compact_prelim.md", "only ours is foldover-free"),
           ("compact/compact_prelim.md", "slower than LSCM"),
           ("charts/thingi_scale.md", "stratified set is mostly valid"), ("pareto/runtime_pareto.md", "")],
    "05": [("compact/compact_prelim.md", "only ours is foldover-free"),
           ("compact/compact_prelim.md", "Hand: LSCM, ARAP, SLIM-1k and BFF all fold"),
           ("compact/compact_prelim.md", "Bob: "), ("compact/compact_prelim.md", "Camel: "),
           ("failure-modes/slim_failure_modes.md", "")],
    "06": [("ntk/ntk_compact_controls.md", ""), ("ablation/ablation_prelim.md", "bandwidth rows")],
    "07": [("charts/thingi_scale.md", "small-chart sweep is almost all valid"), ("generated/amara_coverage_validity.md", "")],
    "09": [("compact/compact_prelim.md", "Camel: LSCM and ARAP still fold"),
           ("compact/compact_prelim.md", "OptCuts resolves Hand and Camel")],
}

@dataclass(frozen=True)
class Claim:
    """One row of the claims checklist.

    ``source``: the report it was read from, relative to ``results/`` (None for
    a table without one); ``table``: the paper's table number (LaTeX order) or
    None; ``claim``: the paper's claim as the report words it; ``verdict``:
    ``holds`` / ``does not hold here`` / ``not tested`` / ``not run``;
    ``detail``: our numbers; ``checks``: the numeric comparisons the verdict
    rests on (:class:`~neuraluv_paper.claim_rules.Check`: paper, ours, rule);
    empty for a **qualitative** claim (a category match, no number compared).
    """

    source: str | None
    table: int | None
    claim: str
    verdict: str
    detail: str
    checks: tuple = ()

    @property
    def numeric(self):
        """True when the verdict comes from numeric checks with a stated tolerance and direction."""
        return bool(self.checks)


def heading(label, what):
    """A report's heading: the paper's number and label of the table it regenerates, then what it is.

    Examples
    --------
    >>> heading("tab:compact_prelim", "compact pre-cut charts")
    'Table 1 (tab:compact_prelim) — compact pre-cut charts'
    """
    number = next(t["number"] for t in PAPER_TABLES if t["label"] == label)
    return f"Table {number} ({label}) — {what}"


def results_dir():
    """The committed ``results/`` folder next to the packages (``$NEURALUV_RESULTS`` overrides it)."""
    env = os.environ.get("NEURALUV_RESULTS")
    return Path(env) if env else Path(__file__).resolve().parents[1] / "results"


def _table_of(source):
    """The paper's table a results file regenerates: its own entry, or, for a subset run in a
    sub-folder (``ablation/paper-camel-1k/ablation_prelim.md``), its folder's main table's.

    Examples
    --------
    >>> _table_of("ablation/ablation_prelim.md")["label"], _table_of("ablation/seeds/ablation_prelim.md")["label"]
    ('tab:ablation_prelim', 'tab:ablation_prelim')
    >>> _table_of("ablation/notes.md") is None
    True
    """
    parts = source.split("/")
    for t in PAPER_TABLES:
        if t["results"] in (source, "/".join(parts[:1] + parts[-1:])):
            return t
    return None


def report_files(root=None):
    """The findings files :func:`findings` reads: ``results/*/*.findings.json`` and those of the subset runs in
    ``results/*/*/`` (sorted paths; empty without a ``results/`` folder)."""
    root = results_dir() if root is None else Path(root)
    return sorted([*root.glob("*/*.findings.json"), *root.glob("*/*/*.findings.json")])


def findings(root=None):
    """Every claim of every committed findings file, in the paper's table order.

    Returns
    -------
    list of Claim
        ``source`` is the report the file sits beside (relative to ``results/``). Empty when
        there is no ``results/`` folder (an installed package).

    Examples
    --------
    >>> import tempfile; d = Path(tempfile.mkdtemp()); (d / "ablation").mkdir()
    >>> _ = (d / "ablation" / "ablation_prelim.findings.json").write_text(json.dumps({"report": "ablation_prelim.md",
    ...     "findings": [{"claim": "k=0 hurts", "verdict": "holds", "detail": "6.75 vs 4.35"}]}))
    >>> [(c.table, c.claim, c.verdict, c.source) for c in findings(d)]
    [(3, 'k=0 hurts', 'holds', 'ablation/ablation_prelim.md')]
    """
    root = results_dir() if root is None else Path(root)
    out = []
    for path in report_files(root):
        data = json.loads(path.read_text(encoding="utf-8"))
        source = (path.parent / data["report"]).relative_to(root).as_posix()
        t = _table_of(source)
        out += [_judge(Claim(source, t["number"] if t else None, f["claim"], f["verdict"], f.get("detail", "")), root)
                for f in data["findings"]]
    return sorted(out, key=lambda c: (c.table is None, c.table or 0))


def _judge(claim, root):
    """A runner's claim, re-judged on its numbers when :mod:`neuraluv_paper.claim_rules` has a rule for it:
    the verdict is "holds" when every check passes; the detail lists paper, ours and the rule of each check."""
    from neuraluv_paper.claim_rules import checks_for

    checks = tuple(checks_for(claim.source, claim.claim, root))
    if not checks or claim.verdict == "not tested":
        return claim
    verdict = "holds" if all(c.ok for c in checks) else "does not hold here"
    detail = "; ".join(c.render() for c in checks)
    if verdict != claim.verdict:
        detail += f" (the report's own category test said: {claim.verdict})"
    return Claim(claim.source, claim.table, claim.claim, verdict, detail, checks)


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
        paper = f"Table {c.table} (`{PAPER_TABLES[c.table - 1]['label']}`)" if c.table else "—"
        evidence = f"`results/{c.source}`" if c.source else "—"
        kind = "numeric" if c.numeric else ("qualitative" if c.verdict in ("holds", "does not hold here") else "")
        verdict = f"**{c.verdict}**" + (f" ({kind})" if kind else "") + (f": {c.detail}" if c.detail else "")
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
        "<!-- generated by book/build.py from neuraluv_paper.claims.claims_page(); do not edit by hand -->",
        "",
        "Every qualitative claim of the paper that a benchmark runner tests is listed below with what our committed",
        "run found, the chapters that discuss it and the report it came with. The rows are read from the findings",
        "each runner writes beside its report (`results/*/*.findings.json`, `neuraluv_paper.claims.findings()`), so",
        "this page, notebook 08 and the checklist at the end of every chapter cannot drift from the numbers. Tables are",
        "numbered as in the paper's LaTeX; a report's file name is its table's label (`compact_prelim.md` is",
        "`tab:compact_prelim`, the paper's Table 1).",
        "",
        "## Claim → notebooks → evidence",
        "",
        "Verdicts: **holds**; **does not hold here** (our data disagree; read the detail before quoting the paper's",
        "number); **not tested** (an optional tool is missing); **not run** (no committed run, or no runner at all).",
        "A **numeric** verdict compares numbers by a stated rule (`neuraluv_paper.claim_rules`): each check prints the",
        "paper's number, ours, the rule with its tolerance and direction (\"|ours − paper| ≤ 5% of paper\", \"ours > k=0 by",
        "more than 1%\") and whether it holds; the claim holds when every check does. Where that differs from the",
        "runner's own category test, the detail says so. A **qualitative** verdict is the runner's category match",
        "(e.g. \"init fail\" in both) with no number compared.",
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


def reference(mesh, method="slim-1k", root=None):
    """A committed Table 1 (tab:compact_prelim) row: the reference point a notebook prints beside its own run.

    Reads ``results/compact/compact_prelim.csv`` (``neuraluv bench compact
    --preset paper``; the paper's Table 1, tab:compact_prelim), so a notebook can set, e.g., SLIM-1k
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
    path = (results_dir() if root is None else Path(root)) / "compact" / "compact_prelim.csv"
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


#: The markers between which docs/RESULTS.md carries :func:`results_index` (regenerated by ``book/build.py``).
INDEX_BEGIN = "<!-- begin: generated by neuraluv_paper.claims.results_index(); do not edit by hand -->"
INDEX_END = "<!-- end: generated -->"


def results_index(root=None):
    """Every committed report: its title, the command and date that produced it, its commit, its verdicts.

    Read from the reports' own header and machine lines and their findings files, so the
    index in ``docs/RESULTS.md`` cannot drift from ``results/`` (Markdown table).

    Examples
    --------
    >>> print(results_index("/nonexistent"))
    | Report | Produced by | Commit | The paper's claims on our data |
    |:--|:--|:--|:--|
    """

    root = results_dir() if root is None else Path(root)
    claims = findings(root) if root.is_dir() else []
    lines = ["| Report | Produced by | Commit | The paper's claims on our data |", "|:--|:--|:--|:--|"]
    reports = sorted(p for p in root.glob("**/*.md") if p.name != "README.md" and "cache" not in p.parts) \
        if root.is_dir() else []
    for path in reports:
        text = path.read_text(encoding="utf-8")
        source = path.relative_to(root).as_posix()
        title = next((ln[2:].strip() for ln in text.splitlines() if ln.startswith("# ")), path.stem)
        made = re.search(r"Produced by `([^`]+)` on ([^.]+UTC)", text)
        machine = next((ln for ln in text.splitlines() if ln.startswith("Machine:")), "")
        commit = re.search(r"commit ([0-9a-f]{7,}(?:\+dirty)?)", machine)
        rows = [c for c in claims if c.source == source]
        tally = ", ".join(f"{n} {v}" for v in ("holds", "does not hold here", "not tested")
                          if (n := sum(c.verdict == v for c in rows))) or "—"
        lines.append(f"| [{_cell(title)}](../results/{source}) | "
                     + (f"`{_cell(made[1])}`, {made[2]}" if made else "—") + f" | {commit[1] if commit else '—'} | {tally} |")
    return "\n".join(lines)
