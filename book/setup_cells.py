#!/usr/bin/env python
"""Write the hosted set-up cell into every notebook (the first code cell, tagged ``hosted-setup``).

    python book/setup_cells.py            # URL from book/_config.yml (repository.url)
    python book/setup_cells.py --check    # exit 1 when a notebook's cell differs (tests/test_notebooks.py checks it too)

The cell's source is :func:`neuraluv.notebook.hosted_setup_source` of the repository URL, so after
publishing the repository set ``repository.url`` in ``book/_config.yml`` and run this script once: the
launch buttons (Binder, Colab) of the book and the cell's ``pip install`` then point at it.
"""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

BOOK = Path(__file__).resolve().parent
NOTEBOOKS = BOOK.parent / "notebooks"
TAG = "hosted-setup"
#: jupyter-book collapses it (the page shows a toggle); nbval runs it (a no-op outside a hosted service)
TAGS = [TAG, "hide-cell"]


def repo_url(config: Path = BOOK / "_config.yml") -> str:
    import yaml

    return str((yaml.safe_load(config.read_text(encoding="utf-8")).get("repository") or {}).get("url") or "")


def lines(source: str) -> list[str]:
    """A cell source as a notebook stores it (lines with their newlines)."""
    return source.splitlines(keepends=True)


def load(path: Path) -> dict:
    """The notebook as plain JSON, key order kept (so a rewrite changes only what it edits)."""
    return json.loads(path.read_text(encoding="utf-8"))


def save(path: Path, nb: dict) -> None:
    path.write_text(json.dumps(nb, indent=1, ensure_ascii=False) + "\n", encoding="utf-8")


def setup_cell_index(nb: dict) -> int | None:
    for i, c in enumerate(nb["cells"]):
        if c["cell_type"] == "code" and TAG in c.get("metadata", {}).get("tags", []):
            return i
    return None


def write(path: Path, source: str, check: bool = False) -> bool:
    """Put the set-up cell (``source``) before the notebook's import cell; True when the notebook changed."""
    nb = load(path)
    i = setup_cell_index(nb)
    if i is not None:
        cell = nb["cells"][i]
        if "".join(cell["source"]) == source and cell["metadata"].get("tags") == TAGS:
            return False
        if not check:
            cell["source"], cell["metadata"]["tags"] = lines(source), list(TAGS)
    elif not check:
        first_code = next(j for j, c in enumerate(nb["cells"]) if c["cell_type"] == "code")
        nb["cells"].insert(first_code, {"cell_type": "code", "execution_count": None,
                                        "id": f"{path.stem.split('_')[0]}-hosted-setup",
                                        "metadata": {"tags": list(TAGS)}, "outputs": [], "source": lines(source)})
    if not check:
        save(path, nb)
    return True


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--url", help="repository URL (default: repository.url of book/_config.yml)")
    p.add_argument("--check", action="store_true", help="only report notebooks whose set-up cell is missing or stale")
    a = p.parse_args(argv)
    sys.path.insert(0, str(BOOK.parent))
    from neuraluv.notebook import hosted_setup_source

    source = hosted_setup_source(a.url or repo_url())
    changed = [nb.name for nb in sorted(NOTEBOOKS.glob("*.ipynb")) if write(nb, source, check=a.check)]
    for name in changed:
        print(("stale: " if a.check else "wrote: ") + name)
    return 1 if (a.check and changed) else 0


if __name__ == "__main__":
    sys.exit(main())
