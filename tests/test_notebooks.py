"""The notebooks and the book built from them.

(a) every notebook is committed clean (no outputs, no execution counts), has the
    Summary / Exercises / References sections, documents the runtime switch and
    checks its facts with ``assert``;
(b) the book builds (Jupyter Book 1, notebooks executed in quick mode) and every
    notebook becomes an HTML page with at least one embedded figure;
(c) a built page renders in headless Chromium to a non-blank screenshot.

Executing the notebooks themselves is nbval's job (``pytest --nbval-lax notebooks``).
"""
import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]
NOTEBOOKS = sorted((ROOT / "notebooks").glob("*.ipynb"))
BOOK = ROOT / "book"
CHROMIUM = shutil.which("chromium") or ("/usr/bin/chromium" if Path("/usr/bin/chromium").exists() else None)
BOOK_TIMEOUT_S = 900

nbformat = pytest.importorskip("nbformat", reason="nbformat not installed (pip install -e '.[test]')")


def _ids(paths):
    return [p.stem for p in paths]


def test_notebooks_exist():
    names = {p.name for p in NOTEBOOKS}
    for required in ["00_quickstart.ipynb", "01_lbo_features.ipynb", "02_tutte_warmup.ipynb",
                     "03_stable_loss.ipynb", "04_flip_rejection.ipynb"]:
        assert required in names
    assert all(re.match(r"\d\d_[a-z0-9_]+\.ipynb$", n) for n in names), "notebooks are named NN_topic.ipynb"


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
    imports = [c for c in code if re.search(r"^(import|from) \w", c.source, re.M)]
    assert len(imports) == 1 and imports[0] is code[0], f"{path.name}: one import cell, first"
    assert "neuraluv" in code[0].source


def test_notebook_switch():
    from neuraluv.notebook import budget, paper_scale

    assert paper_scale({"NEURALUV_PAPER_SCALE": "1"}) and not paper_scale({"NEURALUV_PAPER_SCALE": "0"})
    assert budget("q", "p", scale=False) == "q" and budget("q", "p", scale=True) == "p"


# ---------------------------------------------------------------- the book


@pytest.fixture(scope="module")
def built_book(tmp_path_factory):
    try:
        import jupyter_book  # noqa: F401
    except ImportError:
        pytest.skip('jupyter-book not installed: pip install -e ".[docs]" (Jupyter Book 1, "jupyter-book<2")')
    out = tmp_path_factory.mktemp("book")
    env = dict(os.environ)
    env.pop("NEURALUV_PAPER_SCALE", None)  # quick mode
    proc = subprocess.run([sys.executable, str(BOOK / "build.py"), "--output", str(out)], cwd=ROOT, env=env,
                          capture_output=True, text=True, timeout=BOOK_TIMEOUT_S)
    log = proc.stdout + proc.stderr
    assert proc.returncode == 0, f"book build failed:\n{log[-4000:]}"
    html = out / "_build" / "html"
    assert (html / "index.html").exists()
    return html, log


def test_book_pages_have_figures(built_book):
    html, log = built_book
    assert "Execution Failed" not in log and "Executing notebook failed" not in log, log[-4000:]
    for nb in NOTEBOOKS:
        page = html / "notebooks" / f"{nb.stem}.html"
        assert page.exists(), f"{nb.name} did not become a page"
        text = page.read_text(encoding="utf-8")
        srcs = re.findall(r'<img[^>]*src="([^"]+)"', text)
        figs = [s for s in srcs if "_images/" in s or s.startswith("data:image")]
        assert figs, f"{page.name}: no embedded figure"
        for s in figs:
            if not s.startswith("data:"):
                assert (page.parent / s).resolve().exists(), f"{page.name}: missing image {s}"
    for extra in ("intro.html", "paper_scale.html", "api.html"):
        assert (html / extra).exists()
    api = (html / "api.html").read_text(encoding="utf-8")
    assert "neuraluv.solver" in api and "neuraluv.energy" in api  # autosummary ran
    assert list(html.glob("_autosummary/neuraluv.solver*.html"))


@pytest.mark.skipif(CHROMIUM is None, reason="chromium not installed (Debian: apt-get install -y chromium)")
def test_book_page_renders_in_chromium(built_book, tmp_path):
    html, _ = built_book
    page = html / "notebooks" / f"{NOTEBOOKS[0].stem}.html"
    shot = tmp_path / "page.png"
    cmd = [CHROMIUM, "--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
           "--disable-background-networking", "--disable-component-update", "--disable-sync",
           f"--user-data-dir={tmp_path / 'profile'}", f"--screenshot={shot}", "--window-size=1200,900",
           page.as_uri()]
    subprocess.run(cmd, capture_output=True, timeout=180)
    assert shot.exists(), "chromium wrote no screenshot"
    import matplotlib.image

    img = np.asarray(matplotlib.image.imread(shot))[..., :3].astype(float)
    assert img.shape[:2] == (900, 1200)
    grey = img.mean(axis=2)
    assert grey.std() > 0.05, "screenshot is blank"
    dark = (grey < 0.5).mean()
    assert 0.005 < dark < 0.6, f"implausible share of dark (text) pixels: {dark:.3f}"
