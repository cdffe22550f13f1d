"""The book's execution cache keeps one execution per notebook (notebooks/conftest.py's ``prune``)."""
import importlib.util
from pathlib import Path

import pytest

nbformat = pytest.importorskip("nbformat")
jc = pytest.importorskip("jupyter_cache")

_spec = importlib.util.spec_from_file_location("nb_conftest", Path(__file__).resolve().parents[1] / "notebooks" / "conftest.py")
_mod = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(_mod)
prune = _mod.prune


def test_prune_drops_older_executions_of_a_changed_notebook(tmp_path):
    from jupyter_cache.base import CacheBundleIn

    cache = jc.get_cache(str(tmp_path / "cache"))
    recs = []
    for code in ("x = 1", "x = 2"):  # the notebook's code changed: a second record beside the first
        nb = nbformat.v4.new_notebook(cells=[nbformat.v4.new_code_cell(code)])
        nb.metadata["kernelspec"] = {"name": "python3", "display_name": "Python 3", "language": "python"}
        recs.append(cache.cache_notebook_bundle(CacheBundleIn(nb, str(tmp_path / "a" / "film.ipynb")),
                                                check_validity=False, overwrite=True))
    assert len(cache.list_cache_records()) == 2
    assert prune(cache, "film.ipynb", keep=recs[1].pk) == 1
    assert [r.pk for r in cache.list_cache_records()] == [recs[1].pk]
