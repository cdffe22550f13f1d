"""Every notebook that needs a real mesh, run with ``NEURALUV_DATA`` at an empty folder.

It must stop at its first data cell with one line naming ``make data`` (a
``DataMissing`` shown without a traceback) and print no stand-in result before.
The notebooks run with the data under nbval (``make test-notebooks``); this runs
each one in a kernel up to the cell where it stops (slow tier: a kernel per notebook).
"""
import json
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
NOTEBOOKS = sorted((ROOT / "notebooks").glob("*.ipynb"))
#: A cell that reads a real mesh (directly or through a benchmark runner).
DATA_CALL = re.compile(r"\bload_chart\(|\bdatasets\.load(_charts)?\(|\bbench_compact\.bench\(")

nbclient = pytest.importorskip("nbclient", reason="nbclient not installed (pip install -e '.[test]')")
nbformat = pytest.importorskip("nbformat")


def first_data_cell(nb):
    return next((i for i, c in enumerate(nb.cells) if c.cell_type == "code" and DATA_CALL.search(c.source)), None)


def _needs_data(path):
    return any(DATA_CALL.search("".join(c["source"])) for c in json.loads(path.read_text())["cells"]
               if c["cell_type"] == "code")


NEEDS_DATA = [p for p in NOTEBOOKS if _needs_data(p)]


def test_the_real_mesh_chapters_are_found():
    assert len(NEEDS_DATA) >= 10, [p.name for p in NEEDS_DATA]


@pytest.mark.slow
@pytest.mark.parametrize("path", NEEDS_DATA, ids=[p.stem for p in NEEDS_DATA])
def test_notebook_stops_at_its_first_data_cell(path, tmp_path, monkeypatch):
    empty = tmp_path / "empty-data"
    empty.mkdir()
    monkeypatch.setenv("NEURALUV_DATA", str(empty))
    monkeypatch.delenv("NEURALUV_PAPER_SCALE", raising=False)
    monkeypatch.setenv("MPLBACKEND", "Agg")
    nb = nbformat.read(path, as_version=4)
    stop = first_data_cell(nb)
    nb.cells = nb.cells[:stop + 1]  # the cells after it never run: Run All stops at an error
    client = nbclient.NotebookClient(nb, timeout=900, kernel_name="python3",
                                     resources={"metadata": {"path": str(path.parent)}})
    with pytest.raises(nbclient.exceptions.CellExecutionError):
        client.execute()
    errors = [(i, o) for i, c in enumerate(nb.cells) if c.cell_type == "code"
              for o in c.get("outputs", []) if o.output_type == "error"]
    assert [i for i, _ in errors] == [stop], f"{path.name}: stopped at cells {[i for i, _ in errors]}, not {stop}"
    out = errors[0][1]
    assert out.ename == "DataMissing", (out.ename, out.evalue)
    assert len(out.traceback) == 1 and "\n" not in out.traceback[0], out.traceback
    assert "make data" in out.traceback[0] and str(empty) in out.traceback[0]
    print(f"{path.name}: stops at cell {stop}: {out.traceback[0]}")
    printed = "".join(o.get("text", "") for c in nb.cells[:stop + 1] if c.cell_type == "code" for o in c.outputs)
    assert not re.search(r"stand-in|stands in|procedural .?glove", printed, re.I), printed
