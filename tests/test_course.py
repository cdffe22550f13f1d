"""The course material around the notebooks (issue 30, item 5).

(a) every chapter opens with learning objectives (3-5, as a list) and prerequisites, right after its title;
(b) every chapter with exercises has solution cells (tagged ``solution`` and collapsed in the book) after
    them; nbval executes them with the rest of the notebook;
(c) the hosted set-up cell (the first code cell, ``book/setup_cells.py``) is the same in every notebook, is
    the library's :func:`neuraluv.notebook.hosted_setup_source` for the book's repository URL, does nothing
    locally and, in a simulated Colab / Binder kernel, installs the package and fetches the meshes (the
    install and the download are intercepted, never run);
(d) the book has the syllabus and runtimes pages in its table of contents, the launch-button configuration,
    and the runtimes page renders from the test run's data.
"""
import json
import re
import subprocess
import sys
from pathlib import Path

import pytest

_FIND_SPEC = __import__("importlib.util").util.find_spec
ROOT = Path(__file__).resolve().parents[1]
BOOK = ROOT / "book"
NOTEBOOKS = sorted((ROOT / "notebooks").glob("*.ipynb"))
yaml = pytest.importorskip("yaml")


def _nb(path):
    return json.loads(path.read_text(encoding="utf-8"))


def _src(cell):
    return "".join(cell["source"])


def _book_module(name):
    import importlib.util

    spec = importlib.util.spec_from_file_location(f"book_{name}", BOOK / f"{name}.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


@pytest.mark.parametrize("path", NOTEBOOKS, ids=[p.stem for p in NOTEBOOKS])
def test_objectives_and_prerequisites_follow_the_title(path):
    cells = _nb(path)["cells"]
    assert _src(cells[0]).startswith("# ")
    second = _src(cells[1])
    assert cells[1]["cell_type"] == "markdown" and second.startswith("## Learning objectives"), \
        f"{path.name}: the cell after the title must be '## Learning objectives' (then '## Prerequisites')"
    objectives, prerequisites = second.split("## Prerequisites", 1)
    n = len(re.findall(r"^- ", objectives, re.M))
    assert 3 <= n <= 5, f"{path.name}: {n} learning objectives (3-5)"
    assert re.search(r"^- Chapters:", prerequisites, re.M) and re.search(r"^- Maths:", prerequisites, re.M)
    assert re.search(r"^- Python:", prerequisites, re.M)


@pytest.mark.parametrize("path", NOTEBOOKS, ids=[p.stem for p in NOTEBOOKS])
def test_exercises_have_executed_solution_cells(path):
    cells = _nb(path)["cells"]
    ex = next(i for i, c in enumerate(cells) if c["cell_type"] == "markdown" and "## Exercises" in _src(c))
    sols = [i for i, c in enumerate(cells) if c["cell_type"] == "code" and "solution" in c["metadata"].get("tags", [])]
    assert sols, f"{path.name}: exercises without a solution cell (tag 'solution')"
    assert all(i > ex for i in sols), f"{path.name}: a solution before the exercises"
    for i in sols:
        c = cells[i]
        tags = c["metadata"]["tags"]
        assert {"hide-cell", "hide-input"} & set(tags), f"{path.name}: solution cell {i} is not collapsed in the book"
        assert "raises-exception" not in tags and "skip-execution" not in tags  # nbval runs it, and it must pass
        assert re.match(r"# Exercise \d", _src(c)), f"{path.name}: solution cell {i} does not say which exercise"
        assert re.search(r"^\s*assert\b", _src(c), re.M), f"{path.name}: solution cell {i} checks nothing"
    heading = next(i for i, c in enumerate(cells) if c["cell_type"] == "markdown" and _src(c).startswith("## Solutions"))
    assert ex < heading < min(sols)


def test_hosted_setup_cell_is_the_librarys_for_the_books_url():
    setup_cells = _book_module("setup_cells")
    from neuraluv.notebook import hosted_setup_source

    url = setup_cells.repo_url()
    assert url.startswith("https://")
    want = hosted_setup_source(url)
    for path in NOTEBOOKS:
        nb = _nb(path)
        i = setup_cells.setup_cell_index(nb)
        assert i is not None, f"{path.name}: no hosted set-up cell (python book/setup_cells.py)"
        cell = nb["cells"][i]
        assert _src(cell) == want, f"{path.name}: stale set-up cell (python book/setup_cells.py)"
        assert cell["metadata"]["tags"] == setup_cells.TAGS
    assert setup_cells.main(["--check"]) == 0


def _run_setup_cell(monkeypatch, tmp_path, *, colab=False, env=None, installed=True, checkout=False):
    """Execute the committed set-up cell with subprocess.run intercepted; returns the commands it ran."""
    import importlib.util

    src = _src(_nb(NOTEBOOKS[0])["cells"][_book_module("setup_cells").setup_cell_index(_nb(NOTEBOOKS[0]))])
    calls = []
    monkeypatch.setattr(subprocess, "run", lambda cmd, **kw: calls.append((list(cmd), kw.get("cwd")))
                        or subprocess.CompletedProcess(cmd, 0))
    monkeypatch.setattr(sys, "path", list(sys.path))
    for k in ("NEURALUV_HOSTED", "COLAB_RELEASE_TAG", "BINDER_LAUNCH_HOST", "NEURALUV_REPO"):
        monkeypatch.delenv(k, raising=False)
    for k, v in (env or {}).items():
        monkeypatch.setenv(k, v)
    if colab:
        monkeypatch.setitem(sys.modules, "google.colab", type(sys)("google.colab"))
    monkeypatch.setattr(importlib.util, "find_spec",
                        lambda name, *a: (_FIND_SPEC(name, *a) if installed or name != "neuraluv" else None))
    work = tmp_path / "repo" / "notebooks"
    work.mkdir(parents=True)
    if checkout:
        (tmp_path / "repo" / "neuraluv").mkdir()
        (tmp_path / "repo" / "neuraluv" / "__init__.py").write_text("")
    monkeypatch.chdir(work)
    exec(compile(src, "hosted-setup", "exec"), {"__name__": "__main__"})
    return calls, work


def test_hosted_setup_cell_does_nothing_locally(monkeypatch, tmp_path):
    path = list(sys.path)
    calls, _ = _run_setup_cell(monkeypatch, tmp_path, installed=False)
    assert calls == [] and sys.path == path


def test_hosted_setup_cell_on_colab_clones_installs_and_fetches(monkeypatch, tmp_path):
    from neuraluv.notebook import hosted

    calls, work = _run_setup_cell(monkeypatch, tmp_path, colab=True, installed=False)
    assert hosted()  # the library's test agrees with the cell's
    repo = str(work / "neuraluv-repo")
    (clone, _), (pip, _), (fetch, cwd) = calls
    assert clone[:2] == ["git", "clone"] and clone[-2].startswith("https://") and clone[-1] == repo
    assert pip[:4] == [sys.executable, "-m", "pip", "install"] and pip[-2:] == ["-e", repo + "[render]"]
    assert fetch[0] == sys.executable and "fetch_data()" in fetch[-1] and cwd == repo
    assert sys.path[0] == repo  # importable in this kernel without a restart
    # NEURALUV_REPO overrides what is cloned (a fork, a mirror)
    calls, _ = _run_setup_cell(monkeypatch, tmp_path / "b", colab=True, installed=False,
                               env={"NEURALUV_REPO": "https://example.org/fork.git"})
    assert calls[0][0][-2] == "https://example.org/fork.git"


def test_hosted_setup_cell_on_binder_uses_the_checkout(monkeypatch, tmp_path):
    calls, work = _run_setup_cell(monkeypatch, tmp_path, env={"BINDER_LAUNCH_HOST": "https://mybinder.org/"},
                                  installed=False, checkout=True)
    repo = str(work.parent)
    assert [c[0][:4] for c in calls][0] == [sys.executable, "-m", "pip", "install"] and calls[0][0][-1] == repo + "[render]"
    # already installed (Binder builds environment.yml, which installs the checkout): only the meshes are fetched
    calls, work = _run_setup_cell(monkeypatch, tmp_path / "b", env={"BINDER_LAUNCH_HOST": "x"}, installed=True,
                                  checkout=True)
    assert len(calls) == 1 and "fetch_data()" in calls[0][0][-1] and calls[0][1] == str(work.parent)


def test_hosted_detection():
    from neuraluv.notebook import hosted

    assert not hosted({}, {}) and not hosted({"NEURALUV_HOSTED": "0"}, {})
    assert hosted({"NEURALUV_HOSTED": "1"}, {}) and hosted({"COLAB_RELEASE_TAG": "release-colab_2026"}, {})
    assert hosted({}, {"google.colab": object()}) and hosted({"BINDER_LAUNCH_HOST": "https://mybinder.org/"}, {})


def test_fetch_data_fetches_the_registry_and_the_authored_assets(monkeypatch, tmp_path):
    from neuraluv import datasets
    from neuraluv import notebook as nbhelp

    seen = []
    monkeypatch.setattr(datasets, "fetch_all", lambda source=None, download=True: seen.append("registry") or
                        {"camel_b": tmp_path / "camel_b.obj", "hand": "could not download 'hand'"})
    monkeypatch.setattr(datasets, "fetch_authored", lambda source=None, download=True: seen.append("authored") or
                        {"fuze.obj": tmp_path / "fuze.obj"})
    lines = []
    got = nbhelp.fetch_data(echo=lines.append)
    assert seen == ["registry", "authored"] and set(got) == {"camel_b", "hand", "fuze.obj"}
    assert "2 of 3 files" in lines[0] and "missing: hand" in lines[0]


def test_book_config_launch_buttons_and_pages():
    cfg = yaml.safe_load((BOOK / "_config.yml").read_text(encoding="utf-8"))
    assert cfg["launch_buttons"]["colab_url"] and cfg["launch_buttons"]["binderhub_url"]
    # the chapters are notebooks/NN_*.ipynb at the repository root: the launch URL is path_to_book + page
    assert cfg["repository"]["path_to_book"] == "" and cfg["repository"]["url"]
    toc = (BOOK / "_toc.yml").read_text(encoding="utf-8")
    assert "file: syllabus" in toc and "file: runtimes" in toc
    build = _book_module("build")
    assert {"syllabus.md", "runtimes.md"} <= set(build.SOURCES)


def test_build_resolves_the_placeholder_repository_url(tmp_path):
    build = _book_module("build")
    src = tmp_path / "src"
    src.mkdir()
    (src / "_config.yml").write_text((BOOK / "_config.yml").read_text(encoding="utf-8"), encoding="utf-8")
    assert build.repository_url({"NEURALUV_REPO_URL": "git@github.com:someone/neuraluv.git"}) == \
        "https://github.com/someone/neuraluv"
    out = build.resolve_config(src, tmp_path / "out", {"NEURALUV_REPO_URL": "https://gitlab.com/a/b"})
    assert yaml.safe_load(out.read_text())["repository"]["url"] == "https://gitlab.com/a/b"
    cfg = yaml.safe_load((src / "_config.yml").read_text())
    if cfg["repository"]["url"] == build.PLACEHOLDER_URL and build.repository_url({}) is None:
        out = build.resolve_config(src, tmp_path / "out2", {})
        assert "launch_buttons" not in yaml.safe_load(out.read_text())  # no buttons that point nowhere


def test_syllabus_covers_every_chapter():
    text = (BOOK / "syllabus.md").read_text(encoding="utf-8")
    sessions = re.findall(r"^## Session (\d+)", text, re.M)
    assert 8 <= len(sessions) <= 10 and sessions == [str(i) for i in range(1, len(sessions) + 1)]
    for path in NOTEBOOKS:
        assert path.stem in text, f"the syllabus does not place {path.stem}"


def test_runtimes_page_renders_from_recorded_times(tmp_path):
    rt = _book_module("runtimes")
    data = rt.record({"00_quickstart": 61.04}, scale="quick", machine="Machine: test", path=tmp_path / "r.json")
    data = rt.record({"00_quickstart": 190.0}, scale="paper", machine="Machine: test", path=tmp_path / "r.json")
    page = rt.page(data)
    row = next(ln for ln in page.splitlines() if ln.startswith("| [00_quickstart]"))
    assert "61 s" in row and "3.2 min (measured)" in row
    row = next(ln for ln in page.splitlines() if ln.startswith("| [01_lbo_features]"))
    assert "not measured" in row
    assert set(rt.PAPER_ESTIMATES) == {p.stem.split("_")[0] for p in NOTEBOOKS}
    committed = rt.load()
    assert committed["quick"], "results/notebooks/runtimes.json has no quick times: run the notebook tests"
    assert (BOOK / "runtimes.md").read_text(encoding="utf-8") == rt.page(committed)
