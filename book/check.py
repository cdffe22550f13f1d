#!/usr/bin/env python
"""Check a built book: every notebook is a page with figures, the API pages exist, a page renders in Chromium.

    python book/check.py                 # checks book/_build/html (run `python book/build.py` first)
    python book/check.py --html DIR      # another build

Exit status 0 when every check passes; 1 with one line per failed check.
The Chromium screenshot is skipped (with a note) when no chromium is installed.
"""
from __future__ import annotations

import argparse
import re
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

BOOK = Path(__file__).resolve().parent
NOTEBOOKS = sorted((BOOK.parent / "notebooks").glob("*.ipynb"))


def check_pages(html: Path) -> list[str]:
    errors = []
    if not (html / "index.html").exists():
        return [f"{html}: no index.html (build the book first: python book/build.py)"]
    for nb in NOTEBOOKS:
        page = html / "notebooks" / f"{nb.stem}.html"
        if not page.exists():
            errors.append(f"{nb.name} did not become a page")
            continue
        text = page.read_text(encoding="utf-8")
        if "Traceback (most recent call last)" in text or 'class="output traceback' in text:
            errors.append(f"{page.name}: shows a traceback")
        srcs = re.findall(r'<img[^>]*src="([^"]+)"', text)
        figs = [s for s in srcs if "_images/" in s or s.startswith("data:image")]
        if not figs:
            errors.append(f"{page.name}: no embedded figure")
        for s in figs:
            if not s.startswith("data:") and not (page.parent / s).resolve().exists():
                errors.append(f"{page.name}: missing image {s}")
    for extra in ("intro.html", "glossary.html", "symbols.html", "claims.html", "paper_scale.html", "api.html"):
        if not (html / extra).exists():
            errors.append(f"no {extra}")
    api = html / "api.html"
    if api.exists():
        text = api.read_text(encoding="utf-8")
        if "neuraluv.solver" not in text or not list(html.glob("_autosummary/neuraluv.solver*.html")):
            errors.append("api.html: the autosummary pages of neuraluv.solver are missing")
    return errors


def check_screenshot(html: Path) -> list[str]:
    chromium = shutil.which("chromium") or ("/usr/bin/chromium" if Path("/usr/bin/chromium").exists() else None)
    if chromium is None:
        print("book/check.py: chromium not installed, screenshot check SKIPPED (Debian: apt-get install -y chromium)")
        return []
    import matplotlib.image
    import numpy as np

    page = html / "notebooks" / f"{NOTEBOOKS[0].stem}.html"
    with tempfile.TemporaryDirectory() as tmp:
        shot = Path(tmp) / "page.png"
        cmd = [chromium, "--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
               "--disable-background-networking", "--disable-component-update", "--disable-sync",
               f"--user-data-dir={Path(tmp) / 'profile'}", f"--screenshot={shot}", "--window-size=1200,900",
               page.as_uri()]
        subprocess.run(cmd, capture_output=True, timeout=180)
        if not shot.exists():
            return ["chromium wrote no screenshot"]
        img = np.asarray(matplotlib.image.imread(shot))[..., :3].astype(float)
    if img.shape[:2] != (900, 1200):
        return [f"screenshot has shape {img.shape[:2]}, expected (900, 1200)"]
    grey = img.mean(axis=2)
    if grey.std() <= 0.05:
        return ["screenshot is blank"]
    dark = (grey < 0.5).mean()
    if not 0.005 < dark < 0.6:
        return [f"implausible share of dark (text) pixels in the screenshot: {dark:.3f}"]
    return []


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--html", type=Path, default=BOOK / "_build" / "html", help="the built HTML folder")
    a = p.parse_args(argv)
    errors = check_pages(a.html)
    if not errors:
        errors = check_screenshot(a.html)
    for e in errors:
        print(f"book check failed: {e}", file=sys.stderr)
    if not errors:
        print(f"book check passed: {len(NOTEBOOKS)} notebook pages with figures and the API pages")
    return 1 if errors else 0


if __name__ == "__main__":
    sys.exit(main())
