#!/usr/bin/env python
"""Check a built book: every notebook is a page with figures, the API pages exist, pages render in Chromium.

    python book/check.py                 # checks book/_build/html (run `python book/build.py` first)
    python book/check.py --html DIR      # another build

Checks: every notebook became a page with embedded figures and no traceback; the
intro, paper-scale and API pages exist; headless Chromium renders the first page
(screenshot not blank); the quickstart's interactive solve film (plotly, with an
iteration slider) is in its page, plotly.js is embedded (no CDN), and Chromium
draws it: the figure's div gets plotly's SVG layers and the slider, and a
screenshot of the figure alone shows the det J colours; the Jacobians chapter's
linked surface/UV views outline a hovered face in both views (a hover event is
emitted in Chromium and the outline read back); one figure of every chapter is
photographed alone at the book's width (``check/figures/<chapter>.png``, the figure
named in ``FIGURE_AFTER``) and must not be blank. The screenshots are kept in
``<html>/../check/`` for a person to look at.

Exit status 0 when every check passes; 1 with one line per failed check.
The Chromium checks are skipped (with a note) when no chromium is installed.
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
#: the page that must carry an interactive plotly figure with an iteration slider
PLOTLY_PAGE = "00_quickstart"
#: the page that must carry the linked surface / UV views (hover a face: outlined in both)
LINKED_PAGE = "00b_jacobians_distortion"

# Emits a hover on face 5 of the UV view and writes what the figure's hover script did into the page.
_HOVER_PROBE = """<script>
setTimeout(function () {
  var gd = Array.from(document.querySelectorAll('.plotly-graph-div')).find(function (g) {
    return g.layout && g.layout.meta && g.layout.meta.linked_hover; });
  var out = document.createElement('pre'); out.id = 'hover-probe';
  if (!gd) { out.textContent = 'HOVER none'; document.body.appendChild(out); return; }
  gd.emit('plotly_hover', {points: [{curveNumber: 1, pointNumber: 5}]});
  setTimeout(function () {
    var n = gd.data.length, d = gd._fullData[0];
    out.textContent = 'HOVER ' + JSON.stringify({visible: [gd.data[n - 2].visible, gd.data[n - 1].visible],
      outline: Array.from(gd.data[n - 2].x), face: [d.x[d.i[5]], d.x[d.j[5]], d.x[d.k[5]], d.x[d.i[5]]]});
    document.body.appendChild(out);
  }, 500);
}, 3000);
</script>"""


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
    for extra in ("intro.html", "syllabus.html", "runtimes.html", "glossary.html", "symbols.html", "claims.html",
                  "paper_scale.html", "api.html"):
        if not (html / extra).exists():
            errors.append(f"no {extra}")
    api = html / "api.html"
    if api.exists():
        text = api.read_text(encoding="utf-8")
        if "neuraluv.solver" not in text or not list(html.glob("_autosummary/neuraluv.solver*.html")):
            errors.append("api.html: the autosummary pages of neuraluv.solver are missing")
    return errors


def _chromium():
    return shutil.which("chromium") or ("/usr/bin/chromium" if Path("/usr/bin/chromium").exists() else None)


def _chromium_cmd(chromium, tmp, *extra):
    return [chromium, "--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
            "--disable-background-networking", "--disable-component-update", "--disable-sync",
            f"--user-data-dir={Path(tmp) / 'profile'}", *extra]


def check_screenshot(html: Path) -> list[str]:
    chromium = _chromium()
    if chromium is None:
        print("book/check.py: chromium not installed, screenshot check SKIPPED (Debian: apt-get install -y chromium)")
        return []
    import matplotlib.image
    import numpy as np

    page = html / "notebooks" / f"{NOTEBOOKS[0].stem}.html"
    with tempfile.TemporaryDirectory() as tmp:
        shot = Path(tmp) / "page.png"
        cmd = _chromium_cmd(chromium, tmp, f"--screenshot={shot}", "--window-size=1200,900", page.as_uri())
        subprocess.run(cmd, capture_output=True, timeout=180)
        if not shot.exists():
            return ["chromium wrote no screenshot"]
        img = np.asarray(matplotlib.image.imread(shot))[..., :3].astype(float)
        keep = html.parent / "check"
        keep.mkdir(parents=True, exist_ok=True)
        shutil.copy2(shot, keep / "first_page.png")
    if img.shape[:2] != (900, 1200):
        return [f"screenshot has shape {img.shape[:2]}, expected (900, 1200)"]
    grey = img.mean(axis=2)
    if grey.std() <= 0.05:
        return ["screenshot is blank"]
    dark = (grey < 0.5).mean()
    if not 0.005 < dark < 0.6:
        return [f"implausible share of dark (text) pixels in the screenshot: {dark:.3f}"]
    return []


_ISOLATE = """<script>
(function () {  // show only the plotly figure (a headless screenshot cannot scroll), then let plotly fit it again
  var d = document.querySelector(".plotly-graph-div");
  if (!d) { return; }
  for (var n = d; n && n !== document.body; n = n.parentElement) {
    var p = n.parentElement;
    if (!p) { break; }
    for (var i = 0; i < p.children.length; i++) {
      var c = p.children[i];
      if (c !== n && c.tagName !== "SCRIPT") { c.style.display = "none"; }
    }
  }
  window.scrollTo(0, 0);
  setTimeout(function () { if (window.Plotly) { window.Plotly.Plots.resize(d); } }, 1000);
})();
</script>
"""


#: Which figure of each chapter the book check photographs: the first figure after the code that names this
#: identifier (default: the chapter's first figure). The figures issue 30 fixed, so a person can look at them.
FIGURE_AFTER = {
    "00b_jacobians_distortion": "add_zoom_inset", "02_tutte_warmup": "solve_filmstrip",
    "03_stable_loss": "beta_runs", "03c_recipe_ablation_grid": "best neural attempt", "04_flip_rejection": "fig:runtime_pareto) on our data",
    "05_baselines": "fig6", "06_ntk_probes": "NTK eigvec", "07_atlas_packing": "plot_density", "09_uv_repair": "faces bit-identical",
}

_SHOW_ONE = """<script>
(function () {  // show only one figure, at the book's width (a headless screenshot cannot scroll)
  var img = document.querySelector('img[src="%s"]');
  if (!img) { document.body.style.display = "none"; return; }  // a blank screenshot: the check fails
  for (var n = img; n && n !== document.body; n = n.parentElement) {
    var p = n.parentElement;
    if (!p) { break; }
    for (var i = 0; i < p.children.length; i++) {
      var c = p.children[i];
      if (c !== n && c.tagName !== "SCRIPT" && !c.contains(document.querySelector("article"))) { c.style.display = "none"; }
    }
  }
  window.scrollTo(0, 0);
})();
</script>
"""


def chapter_figure(page: Path) -> str | None:
    """The ``src`` of the figure the check photographs on a chapter page (see :data:`FIGURE_AFTER`)."""
    text = page.read_text(encoding="utf-8")
    marker = FIGURE_AFTER.get(page.stem)
    start = text.find(marker) if marker else 0
    m = re.compile(r'<img[^>]*src="([^"]*(?:_images/|data:image)[^"]*)"').search(text, max(start, 0))
    return m.group(1) if m else None


def check_figures(html: Path) -> list[str]:
    """Photograph one figure of every chapter in Chromium, alone at the book's width; kept in ``check/figures/``."""
    chromium = _chromium()
    if chromium is None:
        print("book/check.py: chromium not installed, figure screenshots SKIPPED")
        return []
    import matplotlib.image
    import numpy as np

    keep = html.parent / "check" / "figures"
    keep.mkdir(parents=True, exist_ok=True)
    errors = []
    for nb in NOTEBOOKS:
        page = html / "notebooks" / f"{nb.stem}.html"
        src = chapter_figure(page) if page.exists() else None
        if src is None:
            errors.append(f"{page.name}: no figure to photograph")
            continue
        probe = page.with_name(f"_check_{page.name}")
        probe.write_text(page.read_text(encoding="utf-8").replace("</body>", _SHOW_ONE % src + "</body>"), encoding="utf-8")
        try:
            with tempfile.TemporaryDirectory() as tmp:
                shot = Path(tmp) / "figure.png"
                subprocess.run(_chromium_cmd(chromium, tmp, "--virtual-time-budget=5000", f"--screenshot={shot}",
                                             "--window-size=1200,900", probe.as_uri()), capture_output=True, timeout=180)
                if not shot.exists():
                    errors.append(f"{page.name}: chromium wrote no screenshot of its figure")
                    continue
                shutil.copy2(shot, keep / f"{nb.stem}.png")
                img = np.asarray(matplotlib.image.imread(shot))[..., :3].astype(float)
        finally:
            probe.unlink(missing_ok=True)
        drawn = float((img.mean(axis=2) < 0.9).mean())  # a line plot on white draws about 1% of the window
        if drawn < 0.003:
            errors.append(f"{page.name}: the screenshot of its figure is (nearly) blank ({drawn:.3f} drawn)")
    return errors


def check_plotly(html: Path) -> list[str]:
    """The quickstart's solve film: a plotly div with frames and a slider, plotly.js embedded, drawn by Chromium."""
    page = html / "notebooks" / f"{PLOTLY_PAGE}.html"
    if not page.exists():
        return [f"{page.name}: missing (the page with the plotly slider)"]
    text = page.read_text(encoding="utf-8")
    divs = re.findall(r'<div id="([^"]+)" class="plotly-graph-div"', text)
    if not divs:
        return [f"{page.name}: no plotly figure (class plotly-graph-div) in the page"]
    errors = []
    if "Plotly.newPlot" not in text or "Plotly.addFrames" not in text:
        errors.append(f"{page.name}: the plotly div has no figure data (Plotly.newPlot, Plotly.addFrames)")
    if '"sliders"' not in text:
        errors.append(f"{page.name}: the plotly figure has no slider")
    if re.search(r'<script[^>]+src="https?://cdn\.plot\.ly', text):
        errors.append(f"{page.name}: plotly.js is loaded from a CDN, not embedded (it would not render offline)")
    chromium = _chromium()
    if errors or chromium is None:
        if chromium is None:
            print("book/check.py: chromium not installed, plotly rendering check SKIPPED")
        return errors
    import matplotlib.image
    import numpy as np

    probe = page.with_name(f"_check_{page.name}")
    probe.write_text(text.replace("</body>", _ISOLATE + "</body>"), encoding="utf-8")
    try:
        with tempfile.TemporaryDirectory() as tmp:
            dom = subprocess.run(_chromium_cmd(chromium, tmp, "--virtual-time-budget=30000", "--dump-dom",
                                               probe.as_uri()),
                                 capture_output=True, timeout=240, text=True).stdout
            start = dom.find(f'id="{divs[0]}"')
            rendered = dom[start:start + 2_000_000] if start >= 0 else ""
            if start < 0:
                errors.append(f"{page.name}: the plotly div is absent from the rendered page")
            elif "main-svg" not in rendered or "slider-container" not in rendered:
                errors.append(f"{page.name}: plotly did not draw the figure (div empty: no SVG layers or no slider)")
            shot = Path(tmp) / "plotly.png"
            subprocess.run(_chromium_cmd(chromium, tmp, "--virtual-time-budget=30000", f"--screenshot={shot}",
                                         "--window-size=1200,900", probe.as_uri()),
                           capture_output=True, timeout=240)
            if not shot.exists():
                return errors + ["chromium wrote no screenshot of the plotly figure"]
            keep = html.parent / "check"
            keep.mkdir(parents=True, exist_ok=True)
            shutil.copy2(shot, keep / "plotly_slider.png")
            img = np.asarray(matplotlib.image.imread(shot))[..., :3].astype(float)
    finally:
        probe.unlink(missing_ok=True)
    sat = img.max(axis=2) - img.min(axis=2)
    coloured = float((sat > 0.25).mean())
    if img.mean(axis=2).std() <= 0.05:
        errors.append("the screenshot of the plotly figure is blank")
    elif coloured < 0.005:
        errors.append(f"the screenshot of the plotly figure shows no coloured mesh ({coloured:.4f} of the pixels coloured)")
    return errors


def check_linked(html: Path) -> list[str]:
    """The Jacobians chapter's linked views: hovering a face (an emitted hover event) outlines it in both views."""
    import json

    page = html / "notebooks" / f"{LINKED_PAGE}.html"
    if not page.exists():
        return [f"{page.name}: missing (the page with the linked views)"]
    text = page.read_text(encoding="utf-8")
    if "plotly_hover" not in text or "linked_hover" not in text:
        return [f"{page.name}: no linked surface/UV figure (plot.plotly_linked_views shown with plot.show_plotly)"]
    chromium = _chromium()
    if chromium is None:
        print("book/check.py: chromium not installed, linked-view hover check SKIPPED")
        return []
    probe = page.with_name(f"_check_{page.name}")
    probe.write_text(text.replace("</body>", _HOVER_PROBE + "</body>"), encoding="utf-8")
    try:
        with tempfile.TemporaryDirectory() as tmp:
            dom = subprocess.run(_chromium_cmd(chromium, tmp, "--virtual-time-budget=30000", "--dump-dom",
                                               probe.as_uri()), capture_output=True, timeout=240, text=True).stdout
    finally:
        probe.unlink(missing_ok=True)
    found = re.search(r"HOVER (\{.*?\})</pre>", dom)
    if not found:
        return [f"{page.name}: the linked figure was not drawn (no hover probe result)"]
    res = json.loads(found.group(1))
    if res["visible"] != [True, True] or res["outline"] != res["face"]:
        return [f"{page.name}: hovering a face did not outline it in both views ({res})"]
    return []


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--html", type=Path, default=BOOK / "_build" / "html", help="the built HTML folder")
    a = p.parse_args(argv)
    errors = check_pages(a.html)
    if not errors:
        errors = check_screenshot(a.html)
    if not errors:
        errors = check_plotly(a.html)
    if not errors:
        errors = check_linked(a.html)
    if not errors:
        errors = check_figures(a.html)
    for e in errors:
        print(f"book check failed: {e}", file=sys.stderr)
    if not errors:
        browser = (f"the plotly solve slider renders ({a.html.parent / 'check'}); hovering a face of the linked views "
                   f"outlines it in both; one figure per chapter photographed ({a.html.parent / 'check' / 'figures'})"
                   ) if _chromium() else "the browser checks SKIPPED (no chromium)"
        print(f"book check passed: {len(NOTEBOOKS)} notebook pages with figures and the API pages; {browser}")
    return 1 if errors else 0


if __name__ == "__main__":
    sys.exit(main())
