"""The notebooks and the book built from them.

(a) every notebook is committed clean (no outputs, no execution counts), has the
    Summary / Exercises / References sections, documents the runtime switch and
    checks its facts with ``assert``; its first code cell is the hosted set-up cell,
    its second the one import cell (the course material: tests/test_course.py);
(b) the notebook switch selects quick or paper-scale settings.

Executing the notebooks is nbval's job (``pytest --nbval-lax notebooks``, which
also hands their outputs to the book's cache); building the book and checking
its pages and a Chromium screenshot is ``make book-check`` (``book/build.py``
then ``book/check.py``). ``make test`` runs all three.
"""
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
NOTEBOOKS = sorted((ROOT / "notebooks").glob("*.ipynb"))

nbformat = pytest.importorskip("nbformat", reason="nbformat not installed (pip install -e '.[test]')")


def _ids(paths):
    return [p.stem for p in paths]


def test_notebooks_exist():
    names = {p.name for p in NOTEBOOKS}
    for required in ["00_quickstart.ipynb", "01_lbo_features.ipynb", "02_tutte_warmup.ipynb",
                     "03_stable_loss.ipynb", "04_flip_rejection.ipynb"]:
        assert required in names
    assert all(re.match(r"\d\d[a-z]?_[a-z0-9_]+\.ipynb$", n) for n in names), "notebooks are named NN_topic.ipynb (NNb_ inserts one)"


@pytest.mark.parametrize("path", NOTEBOOKS, ids=_ids(NOTEBOOKS))
def test_notebook_is_clean_and_complete(path):
    nb = nbformat.read(path, as_version=4)
    nbformat.validate(nb)
    code = [c for c in nb.cells if c.cell_type == "code"]
    md = [c for c in nb.cells if c.cell_type == "markdown"]
    dirty = [i for i, c in enumerate(nb.cells) if c.cell_type == "code" and (c.outputs or c.execution_count is not None)]
    assert not dirty, f"{path.name}: cells {dirty} have outputs or execution counts; clear them before committing"
    headings = [ln.strip("# ").strip() for c in md for ln in c.source.splitlines() if ln.startswith("#")]
    for section in ("Summary", "Exercises", "References"):
        assert section in headings, f"{path.name}: no '## {section}' heading"
    assert any(re.search(r"^\s*assert\b", c.source, re.M) for c in code), f"{path.name}: no assert in any code cell"
    assert md and nb.cells[0].cell_type == "markdown" and nb.cells[0].source.startswith("# "), "opens with a title cell"
    assert "NEURALUV_PAPER_SCALE" in md[0].source, f"{path.name}: the first markdown cell must document the switch"
    setup = [c for c in code if "hosted-setup" in c.metadata.get("tags", [])]
    assert len(setup) == 1 and setup[0] is code[0], f"{path.name}: the hosted set-up cell first (python book/setup_cells.py)"
    code = code[1:]
    imports = [c for c in code if re.search(r"^(import|from) \w", c.source, re.M)]
    assert len(imports) == 1 and imports[0] is code[0], f"{path.name}: one import cell, first after the set-up cell"
    assert "neuraluv" in code[0].source


def test_notebook_switch():
    from neuraluv.notebook import budget, paper_scale

    assert paper_scale({"NEURALUV_PAPER_SCALE": "1"}) and not paper_scale({"NEURALUV_PAPER_SCALE": "0"})
    assert budget("q", "p", scale=False) == "q" and budget("q", "p", scale=True) == "p"


from neuraluv import notebook as nbhelp  # noqa: E402
from neuraluv_paper import claims  # noqa: E402


def _chapter(path):
    return path.stem.split("_")[0]


@pytest.mark.parametrize("path", NOTEBOOKS, ids=_ids(NOTEBOOKS))
def test_chapter_ends_with_its_checklist_and_has_hints(path):
    nb = nbformat.read(path, as_version=4)
    chapter = _chapter(path)
    last = [c for c in nb.cells if c.cell_type == "code"][-1]
    assert f'checklist("{chapter}")' in last.source, f"{path.name}: the last code cell shows checklist({chapter!r})"
    assert chapter in claims.CHAPTER_CLAIMS or chapter == "08"
    md = "\n".join(c.source for c in nb.cells if c.cell_type == "markdown")
    assert "Predict, then run" in md, f"{path.name}: no 'Predict, then run' question"
    exercises = md[md.index("## Exercises"):]
    assert "<summary>Hint</summary>" in exercises, f"{path.name}: exercises without hints"


def test_quiet_environment_without_display():
    env = {}
    changed = nbhelp.quiet_environment(env)
    assert env["PYVISTA_OFF_SCREEN"] == "true" and changed["PYVISTA_OFF_SCREEN"] == "true"
    assert nbhelp.quiet_environment({"DISPLAY": ":0", "PYVISTA_OFF_SCREEN": "true"}) == {}
    assert nbhelp.quiet_environment({"VTK_DEFAULT_OPENGL_WINDOW": "x", "PYVISTA_OFF_SCREEN": "1"}) == {}
