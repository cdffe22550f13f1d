"""Table 5 (tab:thingi_scale): the neural solver on xatlas-cut charts, stratified by size.

The paper cuts Thingi10K meshes into charts with xatlas and reports every
attempted chart with explicit denominators, in two sets: the *first-500*
sweep (the first 500 xatlas charts, small: 4–236 faces) and a *stratified*
set of 47 charts from 1,028 to 196,608 faces. Here the closed and large
meshes of the registry (:data:`neuraluv.datasets.CLOSED`,
:data:`neuraluv.datasets.LARGE`) and pyvista's bundled offline meshes are cut
the same way (``xatlas.Atlas.generate``; each chart's face indices from
``get_mesh_chart``) and charts that fail :func:`neuraluv.topology.is_disk_like`
are set aside (and counted).

xatlas cuts almost no chart above 5,000 faces on these meshes (the largest: 10,336; Thingi10K holds
finely tessellated CAD and scan meshes; the paper's largest charts, 131,072 and
196,608 = 3·4⁸ faces, are such regular tessellations). So the strata above
10,000 faces are filled with xatlas charts of ≥ 1,000 faces refined by midpoint
subdivision (:func:`subdivided_charts`: each level splits every triangle in four
and keeps the chart's shape, boundary and disk topology exactly), marked
``/s<level>`` in the chart name; the 1,000–10,000 stratum holds only native
charts.

For every selected chart the table reports tried / finite / valid counts,
the face range, the median E_SD (of valid charts) and the mean time, per
stratum and overall, beside the paper's rows, and the classical baselines
(our BFF, the BFF command-line tool, SLIM-1k) on the same charts.

Python API: :func:`bench`; command line: ``neuraluv bench charts``.
"""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import trimesh
import xatlas

from neuraluv import plot
from neuraluv.datasets import CLOSED, FETCH_HINT, LARGE, DataMissing, available, data_dir, load, sphere
from neuraluv.errors import NeuralUVError
from neuraluv.meshfix import repair_mesh
from neuraluv.topology import is_disk_like
from neuraluv_paper.baselines import run_baseline
from neuraluv_paper.bench import paper_values as PV
from neuraluv_paper.bench.common import LABELS, iteration_override, neural_options
from neuraluv_paper.bench.provenance import (PAPER_NOTE, BenchOutput, RowLog, command_line, findings_markdown, fmt_num,
                                             fmt_time, fraction, markdown_table, print_report, progress, save_figure,
                                             start_run, write_csv, write_markdown)
from neuraluv_paper.claims import heading

__all__ = ["bench", "add_arguments", "run", "STRATA", "SMALL_STRATA", "FIRST", "stratum", "xatlas_charts", "chart_pool",
           "select_charts", "subdivided_charts", "chart_arrays", "CAPS", "PYVISTA_MESHES", "default_sources"]

#: (low, high, name): a chart with ``low <= faces < high`` falls in the stratum. The paper's
#: stratified set spans 1,028–196,608 faces.
STRATA = [(1000, 10000, "thousands"), (10000, 100000, "tens of thousands"),
          (100000, 200000, "hundreds of thousands")]
#: Strata of the small charts (``--quick``, and the older 10–10,336-face table).
SMALL_STRATA = [(10, 100, "tens"), (100, 1000, "hundreds"), (1000, 10000, "thousands"),
                (10000, math.inf, "tens of thousands")]
#: The small-chart sweep: the first ``FIRST`` xatlas charts of the sources, in order (the paper's "first-500").
FIRST = 500
#: Subdivided copies of a chart enter only strata from this size up (native charts fill the rest).
SUBDIVIDE_FROM = 10000
#: Most charts per stratum of the stratified set (the large ones cost minutes each on a CPU, SLIM-1k most).
CAPS = {"tens of thousands": 12, "hundreds of thousands": 4}
#: The subset label of the first-N sweep's rows.
FIRST_LABEL = "first-N"
#: Offline meshes shipped with pyvista (``pyvista.examples.load_*``), as ``pv:<name>`` sources.
PYVISTA_MESHES = ["ant", "airplane", "nut"]


def stratum(n_faces, strata=STRATA):
    """Name of the size stratum of a chart (None below the smallest).

    Examples
    --------
    >>> stratum(1028), stratum(40000), stratum(196608), stratum(999)
    ('thousands', 'tens of thousands', 'hundreds of thousands', None)
    >>> stratum(12, SMALL_STRATA)
    'tens'
    """
    for lo, hi, name in strata:
        if lo <= n_faces < hi:
            return name
    return None


def _load_source(name):
    """``(V, F)`` of a source: a registry name, ``pv:<name>``, ``sphere`` or ``name@N`` (N midpoint subdivisions)."""
    sub = 0
    if "@" in name:
        name, s = name.split("@", 1)
        sub = int(s)
    if name.startswith("pv:"):
        from pyvista import examples

        m = getattr(examples, f"load_{name[3:]}")().triangulate().clean()
        V = np.asarray(m.points, float)
        F = np.asarray(m.faces).reshape(-1, 4)[:, 1:].astype(np.int64)
    elif name == "sphere":
        V, F = sphere(3)
    else:
        V, F = load(name)

    V, F, _, _ = repair_mesh(V, F)
    if sub:
        for _ in range(sub):
            V, F = trimesh.remesh.subdivide(V, F)
        V, F = np.asarray(V, float), np.asarray(F, np.int64)
    return V, F


def default_sources(large=False):
    """The closed registry meshes plus pyvista's offline meshes (and, with ``large``, the large registry meshes).

    Raises :class:`~neuraluv.datasets.DataMissing` (one line) when a registry mesh is not cached: a sweep
    over fewer meshes than the table's would read as a result.
    """
    names = CLOSED + (LARGE if large else [])
    missing = [n for n in names if not available(n)]
    if missing:
        raise DataMissing(f"the real mesh(es) {', '.join(missing)} not in {data_dir()}: {FETCH_HINT}")
    return names + [f"pv:{n}" for n in PYVISTA_MESHES]


def xatlas_charts(V, F):
    """Cut a mesh into charts with xatlas.

    Parameters
    ----------
    V : (n,3) float array
    F : (m,3) int array

    Returns
    -------
    list of (k,) int arrays
        The input face indices of each chart (together a partition of ``F``).

    Examples
    --------
    >>> from neuraluv.datasets import sphere
    >>> V, F = sphere(2)
    >>> charts = xatlas_charts(V, F)
    >>> sum(len(c) for c in charts) == len(F)
    True
    """
    atlas = xatlas.Atlas()
    atlas.add_mesh(np.ascontiguousarray(V, np.float32), np.ascontiguousarray(F, np.uint32))
    atlas.generate()
    return [np.asarray(atlas.get_mesh_chart(0, c).faces, np.int64) for c in range(atlas.get_mesh_chart_count(0))]


def _chart_mesh(V, F, fidx):
    Fc = F[fidx]
    vi, inv = np.unique(Fc, return_inverse=True)
    return V[vi], inv.reshape(-1, 3).astype(np.int64)


def chart_pool(sources, cache_dir=None, show_progress=False):
    """Every xatlas chart of every source, with its disk-like verdict.

    Returns
    -------
    pool : list of dict
        ``source, chart, faces, disk, reason`` and the chart's ``V, F``.
    failed : list of (source, reason)
        Sources that could not be loaded or cut.
    """
    pool, failed = [], []
    for src in progress(sources, desc="xatlas", disable=not show_progress):
        try:
            V, F = _load_source(src)
            cache = Path(cache_dir) / f"xatlas_{src.replace(':', '_')}.npz" if cache_dir else None
            if cache is not None and cache.exists():
                z = np.load(cache)
                charts = np.split(z["faces"], z["splits"])
            else:
                charts = xatlas_charts(V, F)
                if cache is not None:
                    cache.parent.mkdir(parents=True, exist_ok=True)
                    np.savez_compressed(cache, faces=np.concatenate(charts), splits=np.cumsum([len(c) for c in charts])[:-1])
        except (NeuralUVError, OSError, ValueError, AttributeError) as exc:
            failed.append((src, f"{type(exc).__name__}: {exc}"))
            continue
        for i, fidx in enumerate(charts):
            Vc, Fc = _chart_mesh(V, F, fidx)
            ok, why = is_disk_like(Vc, Fc)
            pool.append({"source": src, "chart": i, "faces": len(fidx), "disk": ok, "reason": why, "V": Vc, "F": Fc})
    return pool, failed


def subdivided_charts(pool, levels=3, low=SUBDIVIDE_FROM, high=STRATA[-1][1], min_faces=1000):
    """Midpoint-subdivided copies of the pool's disk-like charts, for the strata above ``low`` faces.

    Each level splits every triangle into four (``trimesh.remesh.subdivide``):
    the surface, its boundary and its disk topology are unchanged, only the
    tessellation is finer. A copy is listed (its arrays are built on demand by
    :func:`chart_arrays`) when its face count lies in ``[low, high)``.

    Parameters
    ----------
    pool : list of dict
        From :func:`chart_pool`.
    levels : int
        Most subdivision levels (×4 faces each).
    min_faces : int
        Only native charts with at least this many faces are refined.

    Returns
    -------
    list of dict
        Pool entries with ``chart`` = ``"<i>/s<level>"``, ``faces`` = native × 4^level,
        ``level`` and the native chart's ``V, F``.

    Examples
    --------
    >>> from neuraluv.datasets import procedural
    >>> V, F = procedural("disk")
    >>> pool = [{"source": "d", "chart": 0, "faces": len(F), "disk": True, "reason": "", "V": V, "F": F}]
    >>> sub = subdivided_charts(pool, levels=2, low=8 * len(F), high=10**6, min_faces=1)
    >>> [(c["chart"], c["faces"]) for c in sub] == [("0/s2", 16 * len(F))]
    True
    >>> len(chart_arrays(sub[0])[1]) == 16 * len(F)
    True
    """
    out = []
    for c in pool:
        if not c["disk"] or c["faces"] < min_faces or c.get("level"):
            continue
        for lev in range(1, levels + 1):
            n = c["faces"] * 4 ** lev
            if low <= n < high:
                out.append({**c, "chart": f"{c['chart']}/s{lev}", "faces": n, "level": lev})
    return out


def chart_arrays(c):
    """``(V, F)`` of a pool entry, subdividing a :func:`subdivided_charts` copy on demand."""
    V, F = c["V"], c["F"]
    if c.get("level"):
        for _ in range(c["level"]):
            V, F = trimesh.remesh.subdivide(V, F)
        V, F = np.asarray(V, float), np.asarray(F, np.int64)
    return V, F


def select_charts(pool, n_charts=47, strata=STRATA, max_per_stratum=None):
    """Pick disk-like charts evenly across each stratum's size range.

    The budget ``n_charts`` is split evenly over the strata; a stratum with too
    few charts passes its leftover to the others (smallest strata first,
    being the cheapest). Within a stratum the charts are sorted by size and
    picked at evenly spaced ranks, so the selection spans its size range.

    Returns
    -------
    list of dict (the selected pool entries, with ``stratum`` added)
    """
    by = {name: sorted((c for c in pool if c["disk"] and stratum(c["faces"], strata) == name),
                       key=lambda c: (c["faces"], c["source"], c["chart"])) for _, _, name in strata}
    caps = {name: len(v) if max_per_stratum is None else min(len(v), max_per_stratum.get(name, len(v)))
            for name, v in by.items()}
    quota = {name: 0 for name in by}
    left = n_charts
    while left > 0:
        open_ = [n for n in by if quota[n] < caps[n]]
        if not open_:
            break
        share = max(1, left // len(open_))
        for n in open_:
            add = min(share, caps[n] - quota[n], left)
            quota[n] += add
            left -= add
            if left == 0:
                break
    chosen = []
    for name, cs in by.items():
        q = quota[name]
        if q == 0:
            continue
        idx = np.unique(np.round(np.linspace(0, len(cs) - 1, q)).astype(int))
        for i in idx:
            chosen.append({**cs[i], "stratum": name})
    return chosen


def bench(sources=None, *, n_charts=None, preset=None, quick=False, output="results/charts", resume=False, seed=0,
          device="auto", show_progress=True, baselines=("bff", "bff-cli", "slim-1k"), max_large=None, first=None,
          subdivide=3, neural=True, k0=False, from_log=False, args=None, **overrides):
    """Run Table 5 (tab:thingi_scale) over xatlas-cut charts and write ``thingi_scale.{csv,md}``.

    Parameters
    ----------
    sources : list of str, optional
        Mesh sources (registry names, ``pv:ant``..., ``sphere``, ``name@1`` for a
        subdivided copy). Default: :func:`default_sources` with the large meshes
        (quick: ``sphere`` and ``pv:ant``).
    n_charts : int, optional
        Charts of the stratified set (default 47; quick 6).
    baselines : tuple of str
        Classical methods run on the same charts (default: our BFF, the BFF
        command-line tool, SLIM-1k).
    max_large : int, optional
        Cap on charts of the top stratum (the slowest; default from :data:`CAPS`).
    first : int, optional
        Size of the first-N small-chart sweep (default :data:`FIRST`; quick 3; 0: none).
    subdivide : int
        Most midpoint-subdivision levels for the charts of the strata above
        10,000 faces (:func:`subdivided_charts`; 0: native charts only).
    neural : bool
        Run the neural solver (False runs only the baselines: a long run can be
        split over processes, their ``rows.jsonl`` concatenated and the table
        written by a final ``--resume`` run).
    from_log : bool
        Compute nothing: write the table from the rows already in ``rows.jsonl``
        (with ``resume``); jobs without a logged row are listed as not run.
    k0 : bool
        Also solve the stratified charts with ``k=0`` (no LBO features; method
        ``neural-k0``): the paper's k=0 vs k=16 check on its 47 stratified charts.
    **overrides
        SolverConfig overrides for the neural solve (e.g. ``iterations=1000``).

    Returns
    -------
    BenchOutput
        ``extra["summary"]``: per-subset rows; ``rows``: one per chart and method.
    """
    if quick:
        overrides = {"iterations": 30, "retries": 0, **overrides}
    sources = list(sources or (["sphere", "pv:ant"] if quick else default_sources(large=True)))
    n_charts = n_charts or (6 if quick else 47)
    first = (3 if quick else FIRST) if first is None else first
    strata = STRATA if not quick else [(4, 100, "tens"), (100, 1000, "hundreds")]
    nkw = neural_options(preset, quick, seed, device, **overrides)
    out, machine, log = start_run(output, resume=resume, device=device)

    pool, failed = chart_pool(sources, out / "cache", show_progress)
    first_set = pool[:first]
    first_tried = [c for c in first_set if c["disk"]]
    sub = subdivided_charts(pool, subdivide, high=strata[-1][1]) if subdivide and not quick else []
    cap = {} if quick else dict(CAPS)
    if max_large is not None:
        cap[strata[-1][2]] = max_large
    chosen = select_charts(pool + sub, n_charts, strata, cap)
    rejected = [c for c in pool if not c["disk"]]
    too_small = [c for c in pool if c["disk"] and stratum(c["faces"], strata) is None]

    methods = (["neural"] if neural else []) + list(baselines)
    rows, done, not_run = [], {}, []
    jobs = [(c, FIRST_LABEL, m) for c in first_tried for m in methods]
    jobs += [(c, c["stratum"], m) for c in chosen for m in methods + (["neural-k0"] if k0 else [])]
    for c, subset, meth in progress(jobs, desc="charts", disable=not show_progress):
        kw = {"neural": nkw, "neural-k0": {**nkw, "k": 0}}.get(meth, {})
        cfg = {k: v for k, v in kw.items() if k != "device"}
        key = (f"{c['source']}#{c['chart']}", meth, cfg)

        def compute():
            V, F = chart_arrays(c)
            res = run_baseline("neural" if meth == "neural-k0" else meth, V, F, **kw)
            nuv = getattr(res, "neural_uv", None)
            uv = nuv if nuv is not None else res.uv
            return {"status": res.status, "reason": res.reason, "finite": bool(uv is not None and np.isfinite(uv).all()),
                    "valid": bool(res.status in ("ok", "neural") and res.metrics.get("valid")),
                    "esd": res.metrics.get("esd"), "flips": res.metrics.get("flips"),
                    "flip_percent": res.metrics.get("flip_percent"), "min_det": res.metrics.get("min_det"),
                    "time": float(res.time), "attempts": getattr(res, "attempts", 1)}

        k = RowLog.key(key)
        if from_log and k not in done and not log.done(key):
            not_run.append((meth, c["faces"]))
            continue
        if k not in done:  # a chart in both sets is solved once
            done[k] = dict(log.run(key, compute))
        row = dict(done[k])
        row.update({"source": c["source"], "chart": c["chart"], "faces": c["faces"], "stratum": subset,
                    "method": meth, "subdivided": int(c.get("level", 0))})
        rows.append(row)

    summary = _summary(rows, strata, methods + (["neural-k0"] if k0 else []), first_label=f"xatlas first-{first}" if first_tried else None)
    findings = _findings(summary, rows)
    table = []
    for s in summary:
        if s["method"] != "neural":
            continue
        table.append([s["label"], str(s["tried"]), str(s["finite"]), fraction(s["valid"], s["tried"], pct=True),
                      s["face_range"], fmt_num(s["median_esd"]), fmt_time(s["mean_time"]) + "s"])
    ptable = [[f"paper: {k}", str(v["tried"]), str(v["finite"]), f"{v['valid']}/{v['tried']} ({v['valid_percent']}%)",
               f"{v['faces'][0]:,}–{v['faces'][1]:,}", fmt_num(v["median_esd"]), f"{v['mean_time']:.2f}s"]
              for k, v in PV.THINGI_SCALE.items()]
    header = ["Subset", "Tried", "Finite", "Valid", "Face range", "Med. E_SD (valid)", "Mean time"]
    btable = []
    for b in list(baselines) + (["neural-k0"] if k0 else []):
        for s in summary:
            if s["method"] == b:
                btable.append([LABELS.get(b, b), s["label"], fraction(s["valid"], s["tried"], pct=True),
                               fmt_num(s["median_esd"]), fmt_time(s["mean_time"]) + "s"])
    nsub = sum(1 for c in chosen if c.get("level"))
    body = [(f"Neural solver: preset `{nkw['preset']}`" + (f" with overrides {overrides}" if overrides else "")
             + f", seed {seed} (the paper: 1,000–5,000 iterations on CUDA).") if neural else
            "Baselines only (`neural=False`): a part of a split run.",
            f"Sources ({len(sources)}): {', '.join(sources)}. xatlas produced {len(pool)} charts: "
            f"{len(pool) - len(rejected)} disk-like, {len(rejected)} set aside by the disk-like test"
            + (f", {len(too_small)} disk-like but below the smallest stratum" if too_small else "")
            + f"; {len(chosen)} selected over {len({c['stratum'] for c in chosen})} strata"
            + (f", {nsub} of them midpoint-subdivided xatlas charts (name `/s<level>`: xatlas cuts no chart above "
               f"{max(c['faces'] for c in pool if c['disk']):,} faces here)" if nsub else "") + "."
            + (f" The first-{first} sweep: the first {len(first_set)} xatlas charts in source order, "
               f"{len(first_tried)} of them disk-like and tried." if first_tried else ""), "",
            "## Ours", "", markdown_table(header, table), "",
            "## The paper's rows (Thingi10K, CUDA)", "", markdown_table(header, ptable)]
    if btable:
        body += ["", "## Classical baselines (and ours with k=0) on the same charts", "",
                 markdown_table(["Method", "Subset", "Valid", "Med. E_SD (valid)", "Mean time"], btable, "llrrr")]
    fm = findings_markdown(findings)
    if fm:
        body += ["", fm]
    body += ["", f"Paper caption: “{PV.CAPTIONS['tab:thingi_scale']}”"]
    notes = [PAPER_NOTE,
             "Valid = the neural solver returned its own map (not a marked fallback) with finite UVs, zero flipped "
             "triangles and positive minimum det J. Finite = the best neural attempt has finite UVs. "
             "The per-chart rows are in `thingi_scale_runs.csv`."]
    if rejected:
        reasons = {}
        for c in rejected:
            r = c["reason"].split(" (")[0].split(":")[0]
            reasons[r] = reasons.get(r, 0) + 1
        notes.append("Charts set aside by the disk-like test: " + "; ".join(f"{v}× {k}" for k, v in sorted(reasons.items())))
    errs = {}
    for r in rows:
        if r["status"] in ("error", "unavailable", "init fail"):
            e = errs.setdefault((r["method"], r["status"], str(r.get("reason", ""))[:100]), [])
            e.append(r["faces"])
    if not_run:
        by = {}
        for m, f in not_run:
            by.setdefault(m, []).append(f)
        notes.append("Not run (written from the log with `--from-log`; these jobs have no logged row and are left out of "
                     "the denominators): " + "; ".join(f"{LABELS.get(m, m)} on {len(fs)} chart(s) of "
                                                        f"{', '.join(f'{x:,}' for x in sorted(fs))} faces"
                                                        for m, fs in by.items()) + ".")
    if errs:
        notes.append("Rows without a map: " + "; ".join(
            f"{LABELS.get(m, m)}: {len(fs)} × {st} ({why}) on charts of {min(fs):,}–{max(fs):,} faces"
            for (m, st, why), fs in sorted(errs.items())) + ". They count as tried and not valid.")
    if failed:
        notes.append("Sources that could not be used: " + "; ".join(f"{s} ({r})" for s, r in failed))
    if log.skipped:
        notes.append(f"{log.skipped} row(s) taken from the resume log.")
    files = [write_csv(out / "thingi_scale_runs.csv", rows), write_csv(out / "thingi_scale.csv", summary)]
    files.append(_figure(out, rows))
    md = write_markdown(out / "thingi_scale.md", heading("tab:thingi_scale", "xatlas-cut charts, stratified by size"), "\n".join(body)
                        + f"\n\n![valid vs size]({files[-1].name})", command=command_line("charts", args),
                        machine=machine, notes=notes, findings=findings)
    files.append(md)
    return BenchOutput("charts", rows, md.read_text(), files, findings, log.skipped,
                       {"summary": summary, "pool": len(pool), "rejected": len(rejected), "chosen": chosen})


def _summary(rows, strata, methods, first_label=None):
    """Per method: the first-N row (labelled ``first_label``), one row per stratum, and the stratified set."""
    out = []
    for m in methods:
        groups = [(FIRST_LABEL, first_label, [r for r in rows if r["method"] == m and r["stratum"] == FIRST_LABEL])]
        groups += [(name, name, [r for r in rows if r["method"] == m and r["stratum"] == name]) for _, _, name in strata]
        groups.append(("all", "stratified, all", [r for r in rows if r["method"] == m and r["stratum"] != FIRST_LABEL]))
        for name, label, rs in groups:
            if not rs:
                continue
            valid = [r for r in rs if r["valid"]]
            faces = [r["faces"] for r in rs]
            esd = [float(r["esd"]) for r in valid if r.get("esd") is not None and not isinstance(r["esd"], str)]
            out.append({"method": m, "subset": name, "label": label, "tried": len(rs),
                        "finite": sum(bool(r["finite"]) for r in rs),
                        "valid": len(valid), "faces_min": min(faces), "faces_max": max(faces),
                        "face_range": f"{min(faces):,}–{max(faces):,}",
                        "median_esd": float(np.median(esd)) if esd else math.nan,
                        "mean_time": float(np.mean([r["time"] for r in rs]))})
    return out


def _findings(summary, rows):
    F = []
    get = {(s["method"], s["subset"]): s for s in summary}
    alln, small = get.get(("neural", "all")), get.get(("neural", FIRST_LABEL))
    strata = [s for s in summary if s["method"] == "neural" and s["subset"] not in ("all", FIRST_LABEL)]
    if small:
        F.append(("The small-chart sweep is almost all valid (paper: 280/287 = 97.6%)",
                  small["valid"] >= 0.95 * small["tried"],
                  f"{fraction(small['valid'], small['tried'], 'valid', pct=True)} ({small['face_range']} faces)"))
    if alln:
        F.append(("The stratified set is mostly valid (paper: 42/47 = 89.4%)", alln["valid"] >= 0.85 * alln["tried"],
                  f"{fraction(alln['valid'], alln['tried'], 'valid', pct=True)} over {len(strata)} strata "
                  f"({alln['face_range']} faces)"))
    if small and alln:
        fs, fb = small["valid"] / small["tried"], alln["valid"] / alln["tried"]
        F.append(("The valid fraction drops on larger charts (paper: 97.6% small vs 89.4% stratified)", fb < fs,
                  f"valid {100 * fs:.1f}% (first-N) vs {100 * fb:.1f}% (stratified)"))
    if (small or strata) and len(strata) + bool(small) > 1:
        seq = ([small] if small else []) + strata
        med = [s["median_esd"] for s in seq if not math.isnan(s["median_esd"])]
        F.append(("Median E_SD grows with chart size (paper: 5.45 small vs 60.56 stratified)",
                  len(med) > 1 and med[-1] > med[0],
                  "median E_SD " + ", ".join(f"{s['label']} {fmt_num(s['median_esd'])}" for s in seq)))
    for b in ("slim-1k", "bff"):
        pairs = [(s, get.get((b, s["subset"]))) for s in ([small] if small else []) + strata]
        pairs = [(s, t) for s, t in pairs if t is not None]
        if pairs:
            F.append((f"Context (not a claim of the paper): ours vs {LABELS.get(b, b)} on the same charts", None,
                      "; ".join(f"{s['label']}: valid {s['valid']}/{s['tried']} vs {t['valid']}/{t['tried']}, "
                                f"median E_SD {fmt_num(s['median_esd'])} vs {fmt_num(t['median_esd'])}, "
                                f"mean time {fmt_time(s['mean_time'])}s vs {fmt_time(t['mean_time'])}s"
                                for s, t in pairs)))
    k0 = get.get(("neural-k0", "all"))
    if alln and k0:
        def med_det(m):
            d = [float(r["min_det"]) for r in rows if r["method"] == m and r["stratum"] != FIRST_LABEL and r["valid"]
                 and finite_pos(r.get("min_det"))]
            return float(np.median(d)) if d else math.nan

        d16, d0 = med_det("neural"), med_det("neural-k0")
        F.append(("On the stratified charts k=16 solves at least as many charts validly as k=0 (paper: 42/47 vs 41/47)",
                  alln["valid"] >= k0["valid"], f"k=16 {alln['valid']}/{alln['tried']} vs k=0 {k0['valid']}/{k0['tried']}"))
        F.append(("…but with higher median E_SD and a lower median det margin than k=0 (paper: 99.68 vs 41.66; "
                  "0.047 vs 0.067): LBO features are a validity-oriented trade-off at this budget",
                  alln["median_esd"] > k0["median_esd"] and d16 < d0,
                  f"median E_SD k=16 {fmt_num(alln['median_esd'])} vs k=0 {fmt_num(k0['median_esd'])}; "
                  f"median min det J (valid charts) {d16:.3g} vs {d0:.3g}"))
    fails = [r for r in rows if r["method"] == "neural" and not r["valid"]]
    if fails:
        fl = [float(r["flip_percent"]) for r in fails if r.get("flip_percent") is not None and not isinstance(r["flip_percent"], str)]
        F.append(("Failures are near-misses (paper: best flip rates 0.0097%–9.30%)", None,
                  f"{len(fails)} invalid: returned as {', '.join(sorted({r['status'] for r in fails}))}"
                  + (f"; returned-map flip rates {min(fl):.3g}%–{max(fl):.3g}%" if fl else "")))
    return F


def _figure(out, rows):
    plt = plot.pyplot()
    fig, ax = plt.subplots(figsize=(6, 3.6))
    for m, mk in (("neural", "o"), ("bff", "s"), ("slim-1k", "^")):
        rs = [r for r in rows if r["method"] == m]
        if not rs:
            continue
        for ok, col in ((True, "tab:blue" if m == "neural" else "tab:green"), (False, "tab:red")):
            sel = [r for r in rs if bool(r["valid"]) == ok]
            y = [float(r["esd"]) if finite_pos(r.get("esd")) else np.nan for r in sel]
            ax.scatter([r["faces"] for r in sel], y, marker=mk, s=18, color=col, alpha=0.8,
                       label=f"{LABELS.get(m, m)} {'valid' if ok else 'invalid'} ({len(sel)})")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("chart faces")
    ax.set_ylabel("E_SD of the returned map")
    ax.legend(fontsize=7)
    ax.set_title("xatlas-cut charts: E_SD vs size", fontsize=9)
    fig.tight_layout()
    return save_figure(fig, Path(out) / "charts_esd_vs_size.png", dpi=100)


def finite_pos(x):
    try:
        return x is not None and math.isfinite(float(x)) and float(x) > 0
    except (TypeError, ValueError):
        return False


def add_arguments(p):
    p.add_argument("--sources", nargs="+", default=None, metavar="S",
                   help="meshes to cut (registry names, pv:ant/pv:airplane/pv:nut, sphere, name@N = N subdivisions); "
                        "default: cached closed registry meshes + pyvista's offline meshes")
    p.add_argument("--n-charts", type=int, default=None, help="charts of the stratified set (default 47; --quick 6)")
    p.add_argument("--baselines", nargs="*", default=["bff", "bff-cli", "slim-1k"],
                   help="classical methods on the same charts (default: bff bff-cli slim-1k)")
    p.add_argument("--max-large", type=int, default=None, help="cap on charts of the top stratum (100,000-200,000 faces; default 4, and 12 of 10,000-100,000)")
    p.add_argument("--first", type=int, default=None, help=f"size of the first-N small-chart sweep (default {FIRST}; 0: none)")
    p.add_argument("--subdivide", type=int, default=3,
                   help="most midpoint-subdivision levels for charts of the strata above 10,000 faces (default 3; 0: none)")
    p.add_argument("--k0", action="store_true",
                   help="also solve the stratified charts with k=0 (no LBO features): the paper's k=0 vs k=16 check")
    p.add_argument("--from-log", action="store_true",
                   help="with --resume: compute nothing, write the table from rows.jsonl (missing jobs listed as not run)")
    p.add_argument("--no-neural", dest="neural", action="store_false",
                   help="baselines only: split a long run over processes, concatenate the rows.jsonl files, "
                        "then write the table with a final --resume run")


def run(args):
    ov = iteration_override(args)
    sources = args.sources or args.meshes
    res = bench(sources, n_charts=args.n_charts, preset=args.preset, quick=args.quick, output=args.output,
                resume=args.resume, seed=args.seed, device=args.device, show_progress=not args.quiet,
                baselines=tuple(args.baselines), max_large=args.max_large, first=args.first, subdivide=args.subdivide,
                neural=args.neural, k0=args.k0, from_log=args.from_log, args=args, **ov)
    return print_report(res)
