"""nbval hooks: keep each notebook's executed outputs for the book, so every notebook runs once per ``make test``.

``pytest --nbval-lax notebooks`` executes every notebook (each ``assert`` in it
is a test). When all cells of a notebook pass, its outputs are written into the
book's execution cache (jupyter-cache, ``book/_build/.jupyter_cache``, the
cache ``jupyter-book build`` reads with ``execute_notebooks: cache``), so
``make book`` renders them without executing the notebook a second time.
Set ``NEURALUV_BOOK_CACHE=off`` to skip this.

The same hooks time each notebook (the sum of its cells' wall times) and, for the
notebooks whose cells all passed, write the book's *Runtimes* page
(``book/runtimes.py``: ``results/notebooks/runtimes.json`` and ``book/runtimes.md``;
quick or paper-scale after ``NEURALUV_PAPER_SCALE``). ``NEURALUV_RUNTIMES=off`` skips it.
"""
from __future__ import annotations

import copy
import os
from pathlib import Path

_RUNS: dict[Path, dict] = {}
CACHE = Path(__file__).resolve().parents[1] / "book" / "_build" / ".jupyter_cache"


def pytest_runtest_makereport(item, call):
    if call.when != "call" or not hasattr(item, "cell_num") or not hasattr(item, "test_outputs"):
        return
    path = Path(str(item.parent.fspath)).resolve()
    run = _RUNS.setdefault(path, {"outputs": {}, "failed": False, "seconds": 0.0})
    run["seconds"] += call.duration
    if call.excinfo is not None:
        run["failed"] = True
    run["outputs"][item.cell_num] = item.test_outputs or []


def _record_runtimes():
    """Write the passed notebooks' times into the book's Runtimes page (never fails the run)."""
    import json

    def n_code(path):
        return sum(c["cell_type"] == "code" for c in json.loads(path.read_text(encoding="utf-8"))["cells"])

    done = {p.stem: r["seconds"] for p, r in _RUNS.items() if not r["failed"] and len(r["outputs"]) == n_code(p)}
    if not done or os.environ.get("NEURALUV_RUNTIMES", "").lower() == "off":
        return
    try:
        import importlib.util
        import sys

        root = Path(__file__).resolve().parents[1]
        sys.path.insert(0, str(root))
        from neuraluv.notebook import paper_scale

        spec = importlib.util.spec_from_file_location("book_runtimes", root / "book" / "runtimes.py")
        runtimes = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(runtimes)
        data = runtimes.record(done, scale="paper" if paper_scale() else "quick", machine=_MACHINE.get("line", ""))
        runtimes.write_page(data)
    except Exception as exc:  # noqa: BLE001 - timing must not fail the tests
        print(f"notebooks/conftest: could not write the runtimes ({type(exc).__name__}: {exc})")


_MACHINE: dict = {}


def pytest_sessionstart(session):
    """The machine line of the Runtimes page, read before the notebooks load the machine."""
    try:
        import sys

        sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
        from neuraluv.notebook import paper_scale
        from neuraluv_paper.bench.provenance import machine_info, machine_line

        info = machine_info("cpu")
        if not paper_scale():
            info["threads"] = 1  # neuraluv.notebook.setup: quick runs use one torch thread in each kernel
        _MACHINE["line"] = machine_line(info)
    except Exception:  # noqa: BLE001 - timing must not fail the tests
        _MACHINE["line"] = ""


def pytest_sessionfinish(session, exitstatus):
    _record_runtimes()
    if os.environ.get("NEURALUV_BOOK_CACHE", "").lower() == "off" or not _RUNS:
        return
    try:
        import nbformat
        from jupyter_cache import get_cache
        from jupyter_cache.base import CacheBundleIn
    except ImportError:  # the docs extra is not installed: the book executes the notebooks itself
        return
    cache = get_cache(str(CACHE))
    for path, run in _RUNS.items():
        nb = nbformat.read(path, as_version=4)
        code = [c for c in nb.cells if c.cell_type == "code"]
        if run["failed"] or len(run["outputs"]) != len(code):
            continue
        executed = copy.deepcopy(nb)
        count = 0
        for cell in executed.cells:
            if cell.cell_type != "code":
                continue
            outs = run["outputs"].get(count)  # nbval numbers the code cells from 0
            count += 1
            if outs is None:
                break
            cell.outputs = [nbformat.from_dict(_clean(o, count)) for o in outs]
            cell.execution_count = count
        else:
            try:
                rec = cache.cache_notebook_bundle(CacheBundleIn(executed, str(path)), check_validity=False, overwrite=True)
                prune(cache, path.name, keep=rec.pk)
            except Exception as exc:  # a cache problem must not fail the tests; the book then executes the notebook
                print(f"notebooks/conftest: could not cache {path.name} for the book ({type(exc).__name__}: {exc})")


def prune(cache, name, keep):
    """Drop the cache's older executions of notebook ``name`` (any folder) but record ``keep``: a notebook whose
    code changed gets a new record and the old one would stay, each with its figures (two plotly films embedding
    plotly.js are some 5 MB a copy). Returns how many were removed."""
    stale = [r.pk for r in cache.list_cache_records() if Path(r.uri).name == name and r.pk != keep]
    for pk in stale:
        cache.remove_cache(pk)
    return len(stale)


def _clean(out, count):
    out = dict(out)
    kind = out.get("output_type")
    if kind == "execute_result":
        out["execution_count"] = count
        out.setdefault("metadata", {})
    elif kind == "display_data":
        out.setdefault("metadata", {})
        out.pop("transient", None)
    return out
