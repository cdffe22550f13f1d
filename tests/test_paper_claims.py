"""neuraluv_paper.claims: the claims checklist read from the findings files the runners commit."""
import json
import re
from pathlib import Path

import pytest

from neuraluv_paper import claims as nbhelp

ROOT = Path(__file__).resolve().parents[1]
RESULTS = ROOT / "results"
PAPER_TEX = sorted((ROOT.parent / "shared" / "paper").glob("*.txt"))
needs_results = pytest.mark.skipif(not RESULTS.is_dir(), reason="no committed results/ folder")


@needs_results
def test_every_findings_file_matches_its_report():
    """Each committed findings file sits beside its report, belongs to a paper table, and says what the report says."""
    files = nbhelp.report_files()
    assert files, "no committed findings"
    for path in files:
        data = json.loads(path.read_text(encoding="utf-8"))
        report = path.parent / data["report"]
        source = report.relative_to(RESULTS).as_posix()
        assert report.is_file(), f"{source}: findings without their report"
        assert data["findings"], f"{source}: an empty findings file"
        text = report.read_text(encoding="utf-8")
        for f in data["findings"]:
            assert f["verdict"] in {"holds", "does not hold here", "not tested"}, source
            assert f["claim"] in text, f"{source}: the report does not state {f['claim']!r}"
        assert nbhelp._table_of(source) is not None, f"{source} is not in PAPER_TABLES"


def test_findings_written_by_a_runner_are_read_back(tmp_path):
    from neuraluv_paper.bench.provenance import findings_markdown, machine_info, write_markdown

    found = [("A beats B", True, "3 vs 4"), ("C folds", False, "0 flips"), ("D helps", None, "no tool")]
    (tmp_path / "compact").mkdir()
    write_markdown(tmp_path / "compact" / "compact_prelim.md", "T", findings_markdown(found), command="x",
                   machine=machine_info("cpu"), findings=found)
    rows = nbhelp.findings(tmp_path)
    assert [(c.table, c.claim, c.verdict, c.detail) for c in rows] == [
        (1, "A beats B", "holds", "3 vs 4"), (1, "C folds", "does not hold here", "0 flips"),
        (1, "D helps", "not tested", "no tool")]


@needs_results
def test_paper_tables_point_at_real_reports_and_runners():
    from neuraluv_paper.bench import BENCHMARKS

    for t in nbhelp.PAPER_TABLES:
        if t["results"]:
            assert (RESULTS / t["results"]).is_file(), t
        if t["runner"]:
            assert t["runner"] in BENCHMARKS, t
            assert BENCHMARKS[t["runner"]].startswith(f"Table {t['number']}") or "Tables" in BENCHMARKS[t["runner"]], t
    assert [t["number"] for t in nbhelp.PAPER_TABLES] == list(range(1, len(nbhelp.PAPER_TABLES) + 1))


@pytest.mark.skipif(not PAPER_TEX, reason="the paper's LaTeX is not next to the repository")
def test_paper_table_numbers_follow_the_latex():
    text = PAPER_TEX[0].read_text(encoding="utf-8")
    labels = re.findall(r"\\begin\{table\*?\}.*?\\label\{(tab:[^}]+)\}", text, re.S)
    assert labels == [t["label"] for t in nbhelp.PAPER_TABLES]


@needs_results
def test_chapter_selectors_match_committed_claims():
    claims = nbhelp.findings()
    for chapter, selectors in nbhelp.CHAPTER_CLAIMS.items():
        for sel in selectors:
            if isinstance(sel, int):
                assert any(t["number"] == sel for t in nbhelp.PAPER_TABLES)
                continue
            source, text = sel
            assert any(c.source == source and text in c.claim for c in claims), f"{chapter}: {sel} matches no claim"
        assert nbhelp.checklist(chapter).startswith("| Paper |")
    every = nbhelp.checklist("08")
    assert all(c.claim.replace("|", "\\|") in every for c in claims)
    assert every.count("**not run**") == sum(t["results"] is None for t in nbhelp.PAPER_TABLES)


@needs_results
def test_book_claims_page_is_current():
    page = ROOT / "book" / "claims.md"
    assert page.read_text(encoding="utf-8") == nbhelp.claims_page(), "regenerate it: python book/build.py (or write claims_page())"


@needs_results
def test_results_doc_index_is_current():
    from neuraluv_paper.claims import INDEX_BEGIN, INDEX_END

    text = (ROOT / "docs" / "RESULTS.md").read_text(encoding="utf-8")
    block = text.split(INDEX_BEGIN, 1)[1].split(INDEX_END, 1)[0].strip()
    assert block == nbhelp.results_index(), "regenerate it: python book/build.py"
    assert all(f"../results/{p.relative_to(RESULTS).as_posix()}" in block
               for p in RESULTS.glob("*/*.md") if p.name != "README.md")


@pytest.mark.parametrize("op, ours, ref, tol, absolute, ok", [
    ("≈", 4.14, 4.13, 0.05, False, True), ("≈", 4.37, 14.04, 0.05, False, False),   # within ±5% of the paper
    (">", 4.01, 4.00, 0.01, False, False), (">", 4.05, 4.00, 0.01, False, True),     # higher by more than 1%
    ("<", 0.66, 0.73, 0.01, False, True), ("<", 0.729, 0.73, 0.01, False, False),
    ("≥", 97.0, 97.6, 0.02, False, True), ("≥", 90.0, 97.6, 0.02, False, False),     # at least paper − 2%
    ("≤", 0.0, 0.0, 0.0, True, True), ("≤", 0.01, 0.0, 0.0, True, False),
    ("≈", float("nan"), 4.0, 0.05, False, False), ("≈", float("inf"), 4.0, 0.05, False, False),
])
def test_check_rule_direction_and_tolerance(op, ours, ref, tol, absolute, ok):
    from neuraluv_paper.claim_rules import Check

    c = Check("x", ours, op, ref, tol=tol, absolute=absolute)
    assert c.ok is ok
    assert c.render().endswith("holds" if ok else "fails") and "rule " in c.render()


@needs_results
def test_claims_compare_numbers_not_categories():
    """The claims the issue found judged by category now fail on their numbers, with the rule printed."""
    rows = {(c.source, c.claim): c for c in nbhelp.findings()}
    bob = rows["failure-modes/slim_failure_modes.md", "Bob / BFF: paper reports E_SD=14.04"]
    assert bob.numeric and bob.verdict == "does not hold here"
    assert "paper 14.04" in bob.detail and "ours 4.369" in bob.detail and "≤ 5% of paper" in bob.detail
    k16 = next(c for (s, t), c in rows.items() if s == "charts/thingi_scale.md" and t.startswith("…but with higher median"))
    assert k16.numeric and k16.verdict == "does not hold here" and "by more than 1% of k=0" in k16.detail


@needs_results
def test_every_rule_matches_a_claim_and_verdicts_follow_the_checks():
    from neuraluv_paper.claim_rules import RULES

    claims = nbhelp.findings()
    for report, start in RULES:
        assert any(c.source and c.source.endswith(report) and c.claim.startswith(start) and c.numeric for c in claims), \
            f"rule {(report, start)} judges no committed claim (renamed?)"
    for c in claims:
        if c.numeric:
            assert c.verdict == ("holds" if all(k.ok for k in c.checks) else "does not hold here"), c.claim
    page = nbhelp.claims_page()
    judged = [c for c in claims if c.verdict in ("holds", "does not hold here")]
    assert page.count("(numeric)") + page.count("(qualitative)") == len(judged)
