"""The book's *Runtimes* page: each chapter's measured wall time, written by the notebook test run.

``pytest --nbval-lax notebooks`` (``make test-notebooks``) times every notebook it executes
(``notebooks/conftest.py``: the sum of its cells' wall times, kernel start-up excluded) and, when all of a
notebook's cells passed, calls :func:`record`: the time goes into ``results/notebooks/runtimes.json``
under ``quick`` or, when the run had ``NEURALUV_PAPER_SCALE=1``, under ``paper``, with the machine line and
the commit; then :func:`write_page` renders ``book/runtimes.md`` from that file. A paper-scale time that was
never measured is shown as the estimate in :data:`PAPER_ESTIMATES`, labelled as one, with its derivation.
"""
from __future__ import annotations

import json
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
DATA = ROOT / "results" / "notebooks" / "runtimes.json"
PAGE = ROOT / "book" / "runtimes.md"

#: Per-solve costs the estimates use: ``neuraluv bench speed`` (results/speed/speed.md, 2-core AMD EPYC, torch 2 threads),
#: the `paper` preset's 5,000 iterations end to end.
_CAMEL, _HAND = 105, 246

#: chapter -> (estimated paper-scale seconds beyond the quick run, or None; how the estimate was derived)
PAPER_ESTIMATES = {
    "00": (_CAMEL, "one `paper` solve of Camel (105 s in results/speed/speed.md) instead of the `fast` one"),
    "00b": (0, "nothing to scale: the same run"),
    "01": (0, "k = 16 instead of 8 eigenfunctions: seconds"),
    "02": (2 * _HAND, "two `paper` solves of Hand (246 s each, results/speed/speed.md), Tutte and random start"),
    "03": (_CAMEL, "one `paper` solve of Camel (105 s)"),
    "03b": (4 * _CAMEL, "four 5,000-iteration solves of Camel (`paper`, `literal`, beta2, guards off; 105 s each)"),
    "03c": (34 * _CAMEL, "7 variants x 3 seeds at 5,000 iterations with 2 retries: 15 valid solves plus 3 attempts for each "
                         "of the 6 folding ones, and 1 more in section 5: about 34 solves of Camel at 105 s"),
    "03d": (None, "8 solves of 2,000 steps (4 methods x Camel and Hand, the `fast` network or free UVs), 8 of 10 s, "
                  "14 ablation solves and the lr sweep: several minutes at the `fast` preset's step cost, which "
                  "results/speed does not give for 2,000 fixed steps; not measured"),
    "04": (_CAMEL + 5 * 21, "one `paper` solve of Camel (105 s) and five 1,000-iteration Adam runs of the paper network "
                            "(21 ms per iteration on Camel, results/speed/speed.md)"),
    "05": (_CAMEL + _HAND + 28, "`paper` solves of Hand and Camel (246 + 105 s) and SLIM-1k on both (22 + 6 s)"),
    "06": (None, "two 5,000-iteration solves of Camel (2 x 105 s) plus NTK probes of the 5x256 network at 5 steps each: "
                 "the probes are not measured here; the chapter's own estimate is most of an hour"),
    "07": (None, "the full-size generated asset and the cow atlas with the `paper` preset: the `fast` atlas takes 8 s "
                 "(median generated) and 12 s (cow) in results/speed/atlas.md, and a `paper` chart solve costs 16-27x "
                 "a `fast` one there, so several minutes; not measured"),
    "08": (0, "reads the committed reports; the one live row uses the `fast` preset either way"),
    "09": (None, "two `paper` solves of Camel (2 x 105 s), the cow atlas with the `paper` preset (minutes, see 07) and "
                 "the neural repairs: more than 5 minutes; not measured"),
}


def load(path: Path = DATA) -> dict:
    if path.exists():
        return json.loads(path.read_text(encoding="utf-8"))
    return {"quick": {}, "paper": {}}


def record(times: dict, *, scale: str, machine: str, path: Path = DATA) -> dict:
    """Merge ``{notebook stem: seconds}`` into the ``scale`` ("quick" or "paper") entries of ``path``."""
    data = load(path)
    for stem, seconds in times.items():
        data.setdefault(scale, {})[stem] = {"seconds": round(float(seconds), 1), "machine": machine}
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(data, indent=1, sort_keys=True) + "\n", encoding="utf-8")
    return data


def _fmt(s):
    if s is None:
        return "–"
    return f"{s:.0f} s" if s < 120 else f"{s / 60:.1f} min"


def page(data: dict, notebooks=None) -> str:
    """The Markdown of ``book/runtimes.md``."""
    notebooks = notebooks or sorted((ROOT / "notebooks").glob("*.ipynb"))
    quick, paper = data.get("quick", {}), data.get("paper", {})
    rows, machines = [], []
    total_q = 0.0
    for nb in notebooks:
        stem, ch = nb.stem, nb.stem.split("_")[0]
        q = quick.get(stem)
        if q:
            total_q += q["seconds"]
            machines.append(q["machine"])
        p = paper.get(stem)
        extra, how = PAPER_ESTIMATES.get(ch, (None, "no estimate"))
        if p:
            pcell, how = _fmt(p["seconds"]) + " (measured)", "measured by the test run with NEURALUV_PAPER_SCALE=1"
            machines.append(p["machine"])
        elif q and extra is not None:
            pcell = f"≈ {_fmt(q['seconds'] + extra)} (estimate)"
        else:
            pcell = "not estimated" if extra is None else f"≈ {_fmt(extra)} + the quick run (estimate)"
        rows.append(f"| [{stem}](notebooks/{stem}.ipynb) | {_fmt(q['seconds']) if q else 'not measured'} | {pcell} | {how} |")
    seen = list(dict.fromkeys(machines))
    lines = [
        "# Runtimes",
        "",
        "How long each chapter takes, for planning a session. **Quick** is the default run (what the test suite and "
        "the book execute): the wall time of the notebook's cells measured by the last test run that passed them all "
        "(`make test-notebooks`, i.e. `pytest --nbval-lax notebooks`; kernel start-up not included). "
        "**Paper-scale** is a run with `NEURALUV_PAPER_SCALE=1` (see {doc}`paper_scale`): measured when such a test "
        "run has been recorded, otherwise an *estimate*: the quick time plus the paper-preset solves the chapter adds, "
        "each costed from the committed speed benchmark (`results/speed/speed.md`, the same kind of 2-core CPU). "
        "A CUDA GPU shortens the paper-scale runs several-fold.",
        "",
        "| chapter | quick (measured) | paper-scale | how the paper-scale figure was obtained |",
        "|:--|--:|--:|:--|",
        *rows,
        "",
        f"All chapters, quick: **{_fmt(total_q)}** of cell time.",
        "",
        "This page is written by the test run (`notebooks/conftest.py` → `book/runtimes.py`, data in "
        "`results/notebooks/runtimes.json`); do not edit it by hand.",
        "",
        *(f"{m}" for m in seen),
        "",
    ]
    return "\n".join(lines)


def write_page(data: dict | None = None, dest: Path = PAGE) -> bool:
    text = page(load() if data is None else data)
    if dest.exists() and dest.read_text(encoding="utf-8") == text:
        return False
    dest.write_text(text, encoding="utf-8")
    return True
