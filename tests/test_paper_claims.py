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
