"""One data folder, and no stand-in for a missing real mesh.

``make data`` and the library read and write the same folder (``datasets.data_dir()``);
a notebook that needs a real mesh which is not there stops with one line naming
``make data`` (``load_chart`` + ``one_line_errors``); a benchmark runner reports
missing inputs as an error (the CLI exits 2 with one line), never as a shorter table.
The notebooks themselves, run without data, are ``test_notebooks_without_data.py``.
"""
import re
from pathlib import Path

import pytest

from neuraluv import datasets
from neuraluv.notebook import load_chart, one_line_errors

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture
def no_data(tmp_path, monkeypatch):
    empty = tmp_path / "empty-data"
    empty.mkdir()
    monkeypatch.setenv("NEURALUV_DATA", str(empty))
    monkeypatch.delenv("NEURALUV_PAPER_SCALE", raising=False)
    return empty


def test_data_dir_is_one_place(monkeypatch, tmp_path):
    monkeypatch.setenv("NEURALUV_DATA", str(tmp_path))
    assert datasets.data_dir() == tmp_path
    monkeypatch.delenv("NEURALUV_DATA")
    assert datasets.checkout() == ROOT  # the tests run from a checkout
    assert datasets.data_dir() == ROOT / ".cache" / "neuraluv-data"
    make = (ROOT / "Makefile").read_text()
    assert not re.search(r"^\s*(export\s+)?NEURALUV_DATA\s*[?:]?=", make, re.M), \
        "the Makefile must not point NEURALUV_DATA elsewhere than the library's default"
    assert "data_scripts/fetch.py" in make.split("\ndata:")[1].split("\n\n")[0]  # `make data` fills data_dir()


def test_load_chart_stops_with_one_line_naming_make_data(no_data):
    for name in ("camel", "hand", "bob"):
        with pytest.raises(datasets.DataMissing) as err:
            load_chart(name, name)
        msg = str(err.value)
        assert "\n" not in msg and "make data" in msg and str(no_data) in msg and repr(name) in msg
        assert err.value.__cause__ is None and err.value.__suppress_context__


def test_load_chart_keeps_deliberate_procedural_charts(no_data):
    name, V, F = load_chart("disk", "camel", n_rings=2)
    assert name == "disk" and F.shape == (24, 3)
    assert load_chart("glove", "glove")[0] == "glove"


def test_notebook_shows_data_missing_as_one_line():
    class Shell:
        def set_custom_exc(self, exc_tuple, handler):
            self.exc, self.handler = exc_tuple, handler

        def _showtraceback(self, etype, value, stb):
            self.shown = stb

    shell = Shell()
    assert one_line_errors(shell)
    assert shell.exc == (datasets.DataMissing,)
    err = datasets.DataMissing("this chapter needs the real mesh 'camel': run `make data`")
    shell.handler(shell, type(err), err, None)
    assert shell.shown == [f"DataMissing: {err}"]
    assert one_line_errors() is False  # outside IPython nothing happens


def test_runner_mesh_loading_raises_instead_of_leaving_rows_out(no_data):
    from neuraluv_paper.bench.charts import default_sources
    from neuraluv_paper.bench.common import load_meshes

    with pytest.raises(datasets.DataMissing, match=r"hand, bob, camel not in .*make data"):
        load_meshes(["hand", "bob", "camel"])
    assert [n for n, *_ in load_meshes(["glove", "components"], quick=True)] == ["glove", "components"]
    with pytest.raises(datasets.DataMissing, match="make data"):
        default_sources()


@pytest.mark.parametrize("argv", [["compact"], ["failure-modes"], ["ablation"], ["pareto"], ["charts"], ["ntk"]],
                         ids=lambda a: a[0])
def test_bench_cli_exits_2_with_one_line_on_missing_meshes(argv, no_data, tmp_path, capsys):
    from neuraluv.cli import main

    out = tmp_path / "out"
    assert main(["bench", *argv, "-o", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and err.startswith("neuraluv: error:") and "make data" in err, err
    assert not list(out.glob("*.md")) and not list(out.glob("*.csv")), "no table for missing inputs"


def test_atlas_speed_refuses_a_missing_mesh(tmp_path, monkeypatch):
    """``bench speed --atlas`` with a registry mesh not in the data folder: an error, not a table without its row."""
    from neuraluv import datasets
    from neuraluv_paper.bench.speed_atlas import atlas_timing

    monkeypatch.setenv("NEURALUV_DATA", str(tmp_path / "empty"))
    with pytest.raises(datasets.DataMissing, match="make data"):
        atlas_timing(meshes=["cow"], n_generated=0, output=tmp_path / "out", show_progress=False)
    assert not (tmp_path / "out" / "atlas.md").exists()
