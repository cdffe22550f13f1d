"""Table 2 (tab:slim_failure_modes): the compact baselines' failure modes.

For each compact chart: components / boundary loops from
:func:`neuraluv.topology.topology_scan`, then SLIM-20, SLIM-1k, BFF and OptCuts
(allowed to recut), each reported as the paper does — the flip rate for maps
that fold, ``E_SD`` for valid maps, or why the method produced nothing
(``init fail``, ``unavailable``, ``error``). Our solver is added as a last
column for context (the paper's table has none).

Python API: :func:`bench`; command line: ``neuraluv bench failure-modes``.
"""
from __future__ import annotations

from neuraluv.topology import topology_scan
from neuraluv_paper.baselines import run_baseline
from neuraluv_paper.bench import paper_values as PV
from neuraluv_paper.bench.common import (DEFAULT_MESHES, LABELS, MESH_LABELS, QUICK_MESHES, iteration_override,
                                         load_meshes, neural_options, result_row)
from neuraluv_paper.bench.provenance import (PAPER_NOTE, BenchOutput, command_line, findings_markdown, fmt_num, fmt_pct,
                                             markdown_table, print_report, progress, start_run, with_paper, write_csv,
                                             write_markdown)
from neuraluv_paper.claims import heading

__all__ = ["bench", "add_arguments", "run", "METHODS", "PAPER_METHODS", "cell"]

#: Table 2's (tab:slim_failure_modes) columns after C/B (the paper's four, then the BFF binary beside our BFF and Blender's unwrappers).
METHODS = ["slim-20", "slim-1k", "bff", "bff-cli", "optcuts", "blender-angle", "blender-conformal",
           "blender-minstretch", "blender-smart"]
#: The paper's own columns (its findings are checked for these).
PAPER_METHODS = ["slim-20", "slim-1k", "bff", "optcuts"]


def cell(row):
    """How the paper reports a method on a chart: flip rate, E_SD or the failure.

    Examples
    --------
    >>> cell({"status": "ok", "valid": False, "flip_percent": 13.56, "esd": 1e9})
    '13.56% flips'
    >>> cell({"status": "ok", "valid": True, "flip_percent": 0.0, "esd": 4.091})
    'E_SD=4.09'
    >>> cell({"status": "init fail"})
    'init fail'
    """
    st = row.get("status")
    if st not in ("ok", "neural", "fallback"):
        return st
    if row.get("valid"):
        return f"E_SD={fmt_num(row['esd'])}"
    return f"{fmt_pct(row['flip_percent'])} flips"


def _paper_cell(mesh, meth):
    v = PV.SLIM_FAILURE_MODES.get(mesh, {}).get(PV.paper_method(meth))
    if v is None:
        return None
    kind, x = v
    if kind == "flips":
        return f"{fmt_pct(x)} flips"
    if kind == "esd":
        return f"E_SD={fmt_num(x)}"
    return kind


def bench(meshes=None, methods=None, *, preset=None, quick=False, output="results/failure-modes", resume=False,
          seed=0, device="auto", show_progress=True, neural=True, args=None, **overrides):
    """Run Table 2 (tab:slim_failure_modes) and write ``slim_failure_modes.{csv,md}`` to ``output``.

    Parameters
    ----------
    meshes : list of str, optional
        Default Hand, Bob, Camel (``quick``: procedural stand-ins).
    methods : list of str, optional
        Default :data:`METHODS` (``quick``: the paper's four, :data:`PAPER_METHODS`).
    neural : bool
        Add our solver as a context column.

    Returns
    -------
    BenchOutput
    """
    names = list(meshes or (QUICK_MESHES if quick else DEFAULT_MESHES))
    methods = list(methods or (PAPER_METHODS if quick else METHODS)) + (["neural"] if neural else [])
    nkw = neural_options(preset, quick, seed, device, **overrides)
    loaded = load_meshes(names, quick)
    out, machine, log = start_run(output, resume=resume, device=device)

    rows, topo = [], {}
    jobs = [(n, V, F, m) for n, V, F in loaded for m in methods]
    for n, V, F in loaded:
        r = topology_scan(V, F)
        topo[n] = (r.components, r.boundary_loops)
    for n, V, F, meth in progress(jobs, desc="failure-modes", disable=not show_progress):
        # same key as the compact benchmark's whole-mesh rows: its log can seed this one
        cfg = {"mode": "whole", **({k: v for k, v in nkw.items() if k != "device"} if meth == "neural" else {})}
        key = (n, meth, cfg)
        row = dict(log.run(key, lambda: result_row(run_baseline(meth, V, F, **(nkw if meth == "neural" else {})))))
        row.update({"mesh": n, "method": meth, "components": topo[n][0], "boundary_loops": topo[n][1]})
        row["cell"] = cell(row)
        rows.append(row)

    header = ["Mesh", "C/B"] + [LABELS.get(m, m) for m in methods]
    table, csv_rows = [], []
    for n, _, _ in loaded:
        c, b = topo[n]
        pcb = PV.SLIM_FAILURE_MODES.get(n, {}).get("cb")
        line = [MESH_LABELS.get(n, n), with_paper(f"{c}/{b}", f"{pcb[0]}/{pcb[1]}" if pcb else None)]
        for m in methods:
            r = next(r for r in rows if r["mesh"] == n and r["method"] == m)
            line.append(with_paper(r["cell"], _paper_cell(n, m)))
            csv_rows.append({"mesh": n, "components": c, "boundary_loops": b, "method": m, "cell": r["cell"],
                             "paper_cell": _paper_cell(n, m), **{k: r.get(k) for k in
                             ("status", "valid", "esd", "flip_percent", "flips", "min_det", "time", "reason")}})
        table.append(line)

    findings = _findings(rows)
    body = [markdown_table(header, table, "l" + "c" * (len(header) - 1))]
    if neural:
        body += ["", f"*Ours* (not in the paper's table): neural solver, preset `{nkw['preset']}`, seed {seed}."]
    fm = findings_markdown(findings)
    if fm:
        body += ["", fm]
    body += ["", f"Paper caption: “{PV.CAPTIONS['tab:slim_failure_modes']}”"]
    notes = [PAPER_NOTE, "C/B: connected components / boundary loops (topology scan).",
             "Cells: the flip rate when the map folds, E_SD when it is valid, otherwise the status "
             "(`init fail`: the method cannot start on this input; `unavailable`: the optional binary is absent; "
             "`error`: it crashed — the paper's 'cleanup fail')."]
    reasons = sorted({f"{LABELS.get(r['method'], r['method'])} on {MESH_LABELS.get(r['mesh'], r['mesh'])}: {r['reason']}"
                      for r in rows if r["status"] not in ("ok", "neural") and r.get("reason")})
    if reasons:
        notes.append("Status details:\n\n" + "\n".join(f"- {s}" for s in reasons))
    if log.skipped:
        notes.append(f"{log.skipped} row(s) taken from the resume log.")
    files = [write_csv(out / "slim_failure_modes.csv", csv_rows)]
    md = write_markdown(out / "slim_failure_modes.md", heading("tab:slim_failure_modes", "compact baseline failure modes"), "\n".join(body),
                        command=command_line("failure-modes", args), machine=machine, notes=notes, findings=findings)
    files.append(md)
    return BenchOutput("failure-modes", rows, md.read_text(), files, findings, log.skipped)


def _findings(rows):
    def get(mesh, meth):
        return next((r for r in rows if r["mesh"] == mesh and r["method"] == meth), None)

    F = []
    for mesh, spec in PV.SLIM_FAILURE_MODES.items():
        for meth in PAPER_METHODS + ["bff-cli"]:  # the BFF binary is judged against the paper's BFF column
            r = get(mesh, meth)
            if r is None or PV.paper_method(meth) not in spec:
                continue
            kind, _ = spec[PV.paper_method(meth)]
            if r["status"] == "unavailable":
                F.append((f"{MESH_LABELS[mesh]} / {LABELS[meth]}: paper reports {_paper_cell(mesh, meth)}", None, r["cell"]))
                continue
            if kind == "flips":
                holds = r["status"] == "ok" and not r.get("valid")
            elif kind == "esd":
                holds = r["status"] == "ok" and bool(r.get("valid"))
            elif kind == "init fail":
                holds = r["status"] == "init fail"
            else:  # cleanup fail
                holds = r["status"] not in ("ok",)
            F.append((f"{MESH_LABELS[mesh]} / {LABELS[meth]}: paper reports {_paper_cell(mesh, meth)}", holds,
                      f"ours: {r['cell']}"))
    return F


def add_arguments(p):
    p.add_argument("--methods", nargs="+", default=None, metavar="M", help=f"methods (default: {' '.join(METHODS)})")
    p.add_argument("--no-neural", action="store_true", help="leave out our solver's context column")


def run(args):
    ov = iteration_override(args)
    res = bench(args.meshes, args.methods, preset=args.preset, quick=args.quick, output=args.output,
                resume=args.resume, seed=args.seed, device=args.device, show_progress=not args.quiet,
                neural=not args.no_neural, args=args, **ov)
    return print_report(res)
