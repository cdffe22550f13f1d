#!/usr/bin/env python
"""Build the neuraluv book (Jupyter Book 1) from ../notebooks.

    python book/build.py                  # sync notebooks into book/notebooks/, build book/_build/html
    python book/build.py --output DIR     # stage a copy in DIR/src and build into DIR/_build/html
    python book/build.py --all            # rebuild every page (the execution cache is still used)
    python book/build.py --serial         # execute notebooks one by one (default: one per CPU core)
    NEURALUV_PAPER_SCALE=1 python book/build.py   # execute the notebooks at paper scale

Jupyter Book 1 only reads files under the book root, so the notebooks (the
single source, committed without outputs) are copied next to ``_toc.yml``; the
copies are git-ignored. Notebooks are executed with a cache (``execute:
execute_notebooks: cache`` in ``_config.yml``): a notebook re-runs only when one
of its code cells changes. Before Sphinx runs, notebooks missing from the cache
are executed in parallel (one per CPU core, jupyter-cache's local multiprocess
executor); Sphinx then only reads the cache. Quick and paper-scale outputs share the cache key,
so rebuild with ``--clean-cache`` after switching ``NEURALUV_PAPER_SCALE``.
Exit status: that of ``jupyter-book build`` (non-zero on a failed build).
"""
from __future__ import annotations

import argparse
import filecmp
import os
import shutil
import subprocess
import sys
from pathlib import Path

BOOK = Path(__file__).resolve().parent
NOTEBOOKS = BOOK.parent / "notebooks"
SOURCES = ["_config.yml", "_toc.yml", "intro.md", "syllabus.md", "runtimes.md", "glossary.md", "symbols.md", "claims.md",
           "paper_scale.md", "api.md"]


def write_claims_page(book: Path = BOOK) -> bool:
    """Regenerate ``claims.md`` from the committed results (``neuraluv_paper.claims.claims_page``); True when it changed."""
    sys.path.insert(0, str(book.parent))
    from neuraluv_paper.claims import claims_page

    page = book / "claims.md"
    text = claims_page()
    if page.exists() and page.read_text(encoding="utf-8") == text:
        return False
    page.write_text(text, encoding="utf-8")
    return True


def write_results_index(book: Path = BOOK) -> bool:
    """Regenerate the report index of ``docs/RESULTS.md`` (``neuraluv_paper.claims.results_index``); True when it changed."""
    sys.path.insert(0, str(book.parent))
    from neuraluv_paper.claims import INDEX_BEGIN, INDEX_END, results_index

    doc = book.parent / "docs" / "RESULTS.md"
    text = doc.read_text(encoding="utf-8")
    head, rest = text.split(INDEX_BEGIN, 1)
    new = head + INDEX_BEGIN + "\n" + results_index() + "\n" + INDEX_END + rest.split(INDEX_END, 1)[1]
    if new == text:
        return False
    doc.write_text(new, encoding="utf-8")
    return True


def write_results_page(dest: Path) -> Path:
    """Copy ``docs/RESULTS.md`` into the book as ``dest/docs/RESULTS.md`` (git-ignored), so the notebooks'
    ``[docs/RESULTS.md](../docs/RESULTS.md)`` citations resolve both in the repository and in the book.

    Its links to the committed reports (``../results/...``, outside the book) become the report's path in code
    style, since Sphinx cannot resolve them.
    """
    import re

    text = (BOOK.parent / "docs" / "RESULTS.md").read_text(encoding="utf-8")
    text = re.sub(r"\[([^\]]*)\]\(\.\./(results/[^)#]*)(#[^)]*)?\)",
                  lambda m: m.group(1) if m.group(1).strip("`") == m.group(2) else f"{m.group(1)} (`{m.group(2)}`)", text)
    out = dest / "docs" / "RESULTS.md"
    out.parent.mkdir(parents=True, exist_ok=True)
    if not out.exists() or out.read_text(encoding="utf-8") != text:
        out.write_text(text, encoding="utf-8")
    return out


def sync_notebooks(src_dir: Path, dest_dir: Path) -> list[Path]:
    """Mirror ``src_dir/*.ipynb`` into ``dest_dir`` (stale copies removed); returns the copies."""
    dest_dir.mkdir(parents=True, exist_ok=True)
    wanted = sorted(src_dir.glob("*.ipynb"))
    names = {p.name for p in wanted}
    for old in dest_dir.glob("*.ipynb"):
        if old.name not in names:
            old.unlink()
    out = []
    for p in wanted:
        q = dest_dir / p.name
        if not q.exists() or not filecmp.cmp(p, q, shallow=False):
            shutil.copy2(p, q)
        out.append(q)
    return out


def stage(dest: Path) -> Path:
    """Copy the book sources and the notebooks into ``dest`` (a fresh source folder)."""
    dest.mkdir(parents=True, exist_ok=True)
    for name in SOURCES:
        shutil.copy2(BOOK / name, dest / name)
    sync_notebooks(NOTEBOOKS, dest / "notebooks")
    write_results_page(dest)
    return dest


def pre_execute(notebooks: list[Path], cache_dir: Path, timeout: int = 600) -> None:
    """Execute the notebooks that have no cache entry yet, in parallel, into ``cache_dir``.

    The cache is the one ``jupyter-book build`` reads (``execute_notebooks:
    cache``), so Sphinx finds every notebook already executed. A notebook that
    fails here is simply not cached: the build executes it again and reports
    the error.
    """
    from jupyter_cache import get_cache
    from jupyter_cache.executors.basic import JupyterExecutorLocalMproc

    cache = get_cache(str(cache_dir))
    uris = [str(nb) for nb in notebooks]
    for uri in uris:
        cache.add_nb_to_project(uri)
    todo = [r.uri for r in cache.list_unexecuted(filter_uris=uris)]
    if not todo:
        return
    print(f"executing {len(todo)} notebook(s) on {os.cpu_count()} processes", flush=True)
    res = JupyterExecutorLocalMproc(cache).run_and_cache(filter_uris=todo, timeout=timeout)
    for uri in res.excepted + res.errored:
        print(f"  failed: {uri} (the build will re-run it and show the error)", flush=True)


def prune_cache(notebooks: list[Path], cache_dir: Path) -> int:
    """Keep one execution per notebook in the cache: the one matching its current code (older records of a
    notebook whose code changed would stay beside it, each with its figures and plotly films). Returns how many
    records were removed."""
    import nbformat
    from jupyter_cache import get_cache

    import importlib.util

    spec = importlib.util.spec_from_file_location("notebooks_conftest", NOTEBOOKS / "conftest.py")
    hooks = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(hooks)
    prune = hooks.prune

    cache = get_cache(str(cache_dir))
    removed = 0
    for nb in notebooks:
        try:
            rec = cache.match_cache_notebook(nbformat.read(str(nb), as_version=4))
        except KeyError:  # not executed yet: the build executes it
            continue
        removed += prune(cache, nb.name, keep=rec.pk)
    return removed


#: the placeholder of ``repository.url`` in ``_config.yml`` (replace it once the repository is published)
PLACEHOLDER_URL = "https://github.com/OWNER/neuraluv"


def repository_url(environ=None, cwd: Path = BOOK.parent) -> str | None:
    """The repository URL for the launch buttons: ``$NEURALUV_REPO_URL``, else ``git remote get-url origin`` (as https)."""
    env = os.environ if environ is None else environ
    url = env.get("NEURALUV_REPO_URL", "").strip()
    if not url:
        try:
            url = subprocess.run(["git", "remote", "get-url", "origin"], cwd=str(cwd), capture_output=True,
                                 text=True, timeout=10).stdout.strip()
        except (OSError, subprocess.SubprocessError):
            url = ""
    if url.startswith("git@") and ":" in url:  # git@github.com:org/repo.git -> https://github.com/org/repo
        host, path = url[4:].split(":", 1)
        url = f"https://{host}/{path}"
    url = url.removesuffix(".git").rstrip("/")
    return url if url.startswith(("https://", "http://")) else None


def resolve_config(src: Path, out: Path, environ=None) -> Path | None:
    """A copy of ``src/_config.yml`` with a real repository URL, or without launch buttons; None: use it as is.

    The committed config carries :data:`PLACEHOLDER_URL`. When a URL is known (:func:`repository_url`) it
    replaces the placeholder; when none is, the launch buttons are left out rather than pointing nowhere.
    """
    import yaml

    cfg = yaml.safe_load((src / "_config.yml").read_text(encoding="utf-8"))
    repo = cfg.get("repository") or {}
    if repo.get("url") and repo["url"] != PLACEHOLDER_URL:
        return None
    url = repository_url(environ)
    if url:
        cfg["repository"] = {**repo, "url": url}
    else:
        cfg.pop("launch_buttons", None)
        cfg.pop("repository", None)
    dest = out / "_build" / "_config.resolved.yml"
    dest.parent.mkdir(parents=True, exist_ok=True)
    dest.write_text(yaml.safe_dump(cfg, sort_keys=False), encoding="utf-8")
    return dest


def jupyter_book() -> str:
    """The ``jupyter-book`` executable of this interpreter's environment."""
    here = Path(sys.executable).parent / "jupyter-book"
    exe = str(here) if here.exists() else shutil.which("jupyter-book")
    if exe is None:
        sys.exit('jupyter-book is not installed: pip install -e ".[docs]" (Jupyter Book 1: "jupyter-book<2")')
    return exe


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--output", type=Path, help="build outside the repository: sources staged in OUTPUT/src, HTML in OUTPUT/_build/html")
    p.add_argument("--all", action="store_true", help="re-write every page (jupyter-book build --all)")
    p.add_argument("--clean-cache", action="store_true", help="drop the execution cache first (re-executes every notebook)")
    p.add_argument("--serial", action="store_true", help="no parallel pre-execution (Sphinx executes one by one)")
    p.add_argument("--strict", action="store_true", help="treat Sphinx warnings as errors (-W --keep-going)")
    a = p.parse_args(argv)

    if write_claims_page():
        print("book/claims.md regenerated from results/ (commit it)", flush=True)
    if write_results_index():
        print("docs/RESULTS.md's report index regenerated from results/ (commit it)", flush=True)
    if a.output is not None:
        out = a.output.resolve()
        src = stage(out / "src")
        copies = sorted((src / "notebooks").glob("*.ipynb"))
    else:
        out, src = BOOK, BOOK
        copies = sync_notebooks(NOTEBOOKS, BOOK / "notebooks")
        write_results_page(BOOK)
    # autosummary stubs are regenerated on every build; stale ones would be excluded by
    # only_build_toc_files (they are not in _toc.yml when the build starts) and the API pages lost
    shutil.rmtree(src / "_autosummary", ignore_errors=True)
    cache_dir = out / "_build" / ".jupyter_cache"
    if a.clean_cache:
        shutil.rmtree(cache_dir, ignore_errors=True)
    # the notebooks say %matplotlib inline; a non-interactive MPLBACKEND in the
    # environment must not turn the kernels' figures off
    os.environ.pop("MPLBACKEND", None)
    os.environ["PYVISTA_OFF_SCREEN"] = "true"
    os.environ["PYDEVD_DISABLE_FILE_VALIDATION"] = "1"
    if not a.serial and copies:
        pre_execute(copies, cache_dir)
    if copies and cache_dir.exists():
        n = prune_cache(copies, cache_dir)
        if n:
            print(f"execution cache: {n} stale record(s) of changed notebooks removed", flush=True)
    cmd = [jupyter_book(), "build", str(src), "--path-output", str(out), "--builder", "html"]
    config = resolve_config(src, out)
    if config is not None:
        cmd += ["--config", str(config)]
    if a.all:
        cmd.append("--all")
    if a.strict:
        cmd += ["-W", "--keep-going"]
    print("+", " ".join(cmd), flush=True)
    rc = subprocess.call(cmd, cwd=str(BOOK.parent))
    if rc == 0:
        print(f"book: {out / '_build' / 'html' / 'index.html'}")
    return rc


if __name__ == "__main__":
    sys.exit(main())
