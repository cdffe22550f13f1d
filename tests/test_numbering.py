"""One numbering: every "Table N" / "Fig. N" / "Figure N" / "Figs. N–M" in the project is the paper's.

The numbers are read from the paper's LaTeX (``../shared/paper/``; the test skips
without it): LaTeX numbers tables and figures separately, in the order of their
captioned ``table``/``table*``/``figure``/``figure*`` environments.

Every capitalised mention in notebooks, results, docs, the book, the code, the
tests and the data scripts is a claim about the paper's numbering; the project's
own plots are "figure" in lower case (or "plot"). A mention is resolved to a
label by, in order:

1. a label written right after it (``Table 1 (tab:compact_prelim)``; several for a
   plural mention: ``Tables 1–2 (tab:compact_prelim, tab:slim_failure_modes)``);
2. the nearest keyword on the same line (:data:`TABLE_KEYS`, :data:`FIGURE_KEYS`, matched at the start of
   a word; a results file name is its table's label, e.g. ``compact_prelim.md``); a keyword of a group
   ("Amara", "NTK") settles only a plural mention ("Tables 7–9"), which must also name only numbers that
   some keyword on the line points at;
3. a plural mention of every table (``Tables 1–9``) needs nothing.

A mention that resolves to nothing fails too ("say which table"), so a changed
number cannot hide in an unlabelled sentence. Logs (``*log*.txt``) are records of
what a command printed and are not scanned.
"""
import re
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PAPER = sorted((ROOT.parent / "shared" / "paper").glob("*.txt")) + sorted((ROOT.parent / "shared" / "paper").glob("*.tex"))
SCANNED_DIRS = ("notebooks", "results", "docs", "book", "neuraluv", "neuraluv_paper", "data_scripts", "tests")
SCANNED_FILES = ("README.md", "Makefile", "pyproject.toml", "environment.yml")
SUFFIXES = {".md", ".py", ".ipynb", ".yml", ".yaml", ".toml", ".sh", ".txt", ".json", ".cfg"}

#: keyword (lower case, substring) -> the labels it points at; the nearest keyword on the line wins.
TABLE_KEYS = {
    "tab:compact_prelim": ["compact_prelim", "compact pre-cut", "pre-cut", "compact chart benchmark",
                           "compact benchmark", "bench compact", "fixed-chart solver", "foldover-free"],
    "tab:slim_failure_modes": ["slim_failure_modes", "failure mode", "failure-mode", "c/b"],
    "tab:ablation_prelim": ["ablation_prelim", "ablation", "spectral init", "random init", "bandwidth rows"],
    "tab:ntk_compact_controls": ["ntk_compact_controls", "ntk", "alignment", "s(16)", "s(4)"],
    "tab:thingi_scale": ["thingi_scale", "thingi", "xatlas", "stratified", "small-chart"],
    "tab:runtime_pareto": ["runtime_pareto", "pareto"],
    "tab:amara_coverage_validity": ["amara_coverage_validity", "coverage", "routed face", "routed-face"],
    "tab:amara_blender_methods": ["amara_blender_methods", "blender"],
    "tab:amara_large_sweep": ["amara_large_sweep", "larger amara", "amara sweep", "large sweep", "larger sweep"],
    ("tab:amara_coverage_validity", "tab:amara_blender_methods", "tab:amara_large_sweep"): ["amara", "generated"],
}
FIGURE_KEYS = {
    "fig:teaser": ["teaser"],
    "fig:motivation": ["motivation", "fold", "mirrored", "artifact", "overlapping"],
    "fig:solver_schematic": ["schematic"],
    "fig:system_pipeline": ["system_pipeline", "pipeline", "validation-first", "atlas validation"],
    "fig:compact_maps": ["compact_maps", "compact maps", "compact benchmark maps"],
    "fig:compact_heatmaps": ["heatmap"],
    ("fig:compact_maps", "fig:compact_heatmaps"): ["compact"],
    "fig:ntk_compact_controls": ["alignment curve", "alignment_curves", "ntk_compact_controls"],
    "fig:ntk_trajectory": ["trajectory"],
    ("fig:ntk_compact_controls", "fig:ntk_trajectory"): ["ntk", "alignment"],
    "fig:runtime_pareto": ["runtime_pareto", "pareto", "validated pass"],
    "fig:amara_gallery": ["gallery", "qualitative"],
    "fig:amara_fallback_limitation": ["amara_fallback_limitation", "rout", "limitation"],
    ("fig:amara_gallery", "fig:amara_fallback_limitation"): ["amara", "generated"],
}

MENTION = re.compile(r"(?<![\w.])(?P<kind>Tables?|Figs?\.|Figures?)[ \u00a0]?"
                     r"(?P<nums>\d+(?:\s*(?:[–—/,&-]|and)\s*\d+)*)(?![\w.]\d)")
LABEL = re.compile(r"\b(tab|fig):([A-Za-z0-9_]+)")
WINDOW = 120


def paper_numbers(paths=PAPER):
    """``{label: number}`` for the paper's tables and figures, numbered as LaTeX does."""
    text = "\n".join(re.sub(r"(?<!\\)%.*", "", p.read_text(encoding="utf-8", errors="replace")) for p in paths)
    numbers, count = {}, {"table": 0, "figure": 0}
    for m in re.finditer(r"\\begin\{(table|figure)\*?\}(.*?)\\end\{\1\*?\}", text, re.S):
        kind, body = m.group(1), m.group(2)
        if "\\caption" not in body:
            continue
        count[kind] += 1
        for label in re.findall(r"\\label\{((?:tab|fig):[^}]+)\}", body):
            numbers[label] = count[kind]
    return numbers


def scanned_files():
    try:
        out = subprocess.run(["git", "ls-files", "--cached", "--others", "--exclude-standard"], cwd=ROOT,
                             capture_output=True, text=True, check=True).stdout.split("\n")
        files = [ROOT / f for f in out if f]
    except (OSError, subprocess.CalledProcessError):
        files = [p for p in ROOT.rglob("*") if ".git" not in p.parts and ".venv" not in p.parts]
    keep = []
    for p in files:
        rel = p.relative_to(ROOT)
        if not p.is_file() or p == Path(__file__).resolve():
            continue
        if rel.as_posix() in SCANNED_FILES or (rel.parts[0] in SCANNED_DIRS and p.suffix in SUFFIXES
                                               and not (p.suffix == ".txt" and "log" in p.name)):
            keep.append(p)
    return sorted(keep)


def _numbers(text):
    out = []
    for part in re.split(r"\s*(?:,|&|and|/)\s*", text):
        a, *b = re.split(r"\s*[–—-]\s*", part)
        out += list(range(int(a), int(b[-1]) + 1)) if b else [int(a)]
    return out


def _keyword_labels(line, start, end, keys, every=False):
    """The labels of the keyword nearest to ``line[start:end]`` (within :data:`WINDOW` characters);
    with ``every``, the labels of all keywords in that window."""
    low, best, seen = line.lower(), None, set()
    for labels, words in keys.items():
        labels = labels if isinstance(labels, tuple) else (labels,)
        for w in words:
            for m in re.finditer(r"(?<![a-z0-9_])" + re.escape(w), low[max(0, start - WINDOW):end + WINDOW]):
                s = m.start() + max(0, start - WINDOW)
                d = s - end if s >= end else (start - (s + len(w)) if s + len(w) <= start else 0)
                seen.update(labels)
                if d >= 0 and (best is None or d < best[0]):
                    best = (d, labels)
    if every:
        return seen
    return best[1] if best else None


def check_line(line, numbers):
    """The problems of one line: ``(mention, message)`` for each mention whose number is not the paper's."""
    problems = []
    mentions = list(MENTION.finditer(line))
    for i, m in enumerate(mentions):
        kind = "tab" if m.group("kind").startswith("Table") else "fig"
        total = max((n for lab, n in numbers.items() if lab.startswith(kind + ":")), default=0)
        nums = _numbers(m.group("nums"))
        stop = mentions[i + 1].start() if i + 1 < len(mentions) else len(line)
        after = line[m.end():min(stop, m.end() + 80)]
        labels = [f"{k}:{n}" for k, n in LABEL.findall(after) if k == kind]
        unknown = [lab for lab in labels if lab not in numbers]
        if unknown:
            problems.append((m.group(0), f"unknown label {unknown[0]} (not in the paper)"))
            continue
        bad = [n for n in nums if not 1 <= n <= total]
        if bad:
            problems.append((m.group(0), f"the paper has no {'Table' if kind == 'tab' else 'Figure'} {bad[0]}"))
            continue
        if labels:
            want = sorted({numbers[lab] for lab in labels})
            ok = nums[0] == want[0] if len(nums) == 1 else sorted(set(nums)) == want
            if not ok:
                problems.append((m.group(0), f"{', '.join(labels)} is {'Table' if kind == 'tab' else 'Fig.'} "
                                             f"{'–'.join(map(str, want))} in the paper"))
            continue
        if len(nums) > 1 and sorted(set(nums)) == list(range(1, total + 1)):
            continue  # "Tables 1–9": all of them
        found = _keyword_labels(line, m.start(), m.end(), TABLE_KEYS if kind == "tab" else FIGURE_KEYS)
        if found is None:
            problems.append((m.group(0), "cannot tell which one this is: write its label after it, e.g. "
                                         "'Table 1 (tab:compact_prelim)'"))
            continue
        if len(nums) == 1 and len(found) > 1:
            problems.append((m.group(0), f"its keyword points at several ({', '.join(found)}): write its label after it"))
            continue
        want = {numbers[lab] for lab in found}
        near = {numbers[lab] for lab in _keyword_labels(line, m.start(), m.end(), TABLE_KEYS if kind == "tab"
                                                        else FIGURE_KEYS, every=True)}
        if not (set(nums) <= want if len(nums) == 1 else want <= set(nums) <= near):
            problems.append((m.group(0), f"this is {' / '.join(found)} by its keyword: "
                                         f"{'Table' if kind == 'tab' else 'Fig.'} {'–'.join(map(str, sorted(want)))}"
                                         " in the paper"))
    return problems


needs_paper = pytest.mark.skipif(not PAPER, reason="the paper's LaTeX is not at ../shared/paper/ (the numbers come from it)")


@needs_paper
def test_paper_numbering_is_read_from_the_latex():
    n = paper_numbers()
    assert n["tab:compact_prelim"] == 1 and n["tab:amara_large_sweep"] == 9
    assert n["fig:teaser"] == 1 and n["fig:ntk_trajectory"] == 8 and n["fig:amara_fallback_limitation"] == 11
    for keys in (TABLE_KEYS, FIGURE_KEYS):
        for labels in keys:
            for lab in labels if isinstance(labels, tuple) else (labels,):
                assert lab in n, f"the keyword map names {lab}, which the paper does not have"


@needs_paper
def test_the_checker_catches_a_wrong_number():
    n = paper_numbers()
    assert not check_line("the paper's Table 1 (tab:compact_prelim) and Figs. 7–8 (NTK)", n)
    assert not check_line("Tables 1–9", n) and not check_line("| Table 7 | coverage |", n)
    assert check_line("the paper's Table 2 (tab:compact_prelim)", n)
    assert check_line("the NTK alignment table (Table 5)", n)
    assert check_line("Figs. 6–7 (NTK trajectory)", n) and check_line("+ Figs. 6–7 | the NTK runner", n)
    assert check_line("as in Table 3", n)  # which one?
    assert check_line("the Amara routing split (Table 7)", n)  # which of the three Amara tables?


@needs_paper
def test_every_table_and_figure_number_is_the_papers():
    numbers = paper_numbers()
    problems = []
    for path in scanned_files():
        for i, line in enumerate(path.read_text(encoding="utf-8", errors="replace").splitlines(), 1):
            problems += [f"{path.relative_to(ROOT)}:{i}: {what!r}: {why}" for what, why in check_line(line, numbers)]
    assert not problems, (f"{len(problems)} mention(s) disagree with the paper's numbering "
                          "(tables and figures numbered as in its LaTeX):\n" + "\n".join(problems))
