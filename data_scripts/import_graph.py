"""Import measurements of the ``neuraluv`` package: import time, CLI start-up, in-function imports, cycles.

Run from the repository root (the package is read from ``./neuraluv``; the timings run
``sys.executable`` with ``PYTHONPATH`` set to the repository root)::

    python data_scripts/import_graph.py [--importtime] [--help-time] [--imports] [--cycles]
                                        [--runs 5] [--json OUT.json]

No flag = all four. What each reports:

``--importtime``  ``python -X importtime -c "import neuraluv"``, ``--runs`` times after one
    untimed warm-up: the median of the cumulative microseconds of the top-level ``neuraluv``
    line (and of the sum of every line's self time, i.e. the whole import including the
    interpreter's own start-up imports); then, in a fresh interpreter, whether
    ``import neuraluv`` left ``torch``, ``scipy``, ``numpy``, ``matplotlib`` in ``sys.modules``.
``--help-time``   the wall time of ``neuraluv --help`` (the console script next to
    ``sys.executable``, else on ``PATH``), ``--runs`` runs after one untimed warm-up, the
    median; which of torch / scipy / numpy / matplotlib the CLI parser imports, the import
    chain that first loads each, and the ``neuraluv`` modules it loads (one extra
    ``-X importtime`` run of the same script).
``--imports``     an ``ast`` walk of every ``neuraluv/**/*.py``: ``import`` / ``from ... import``
    statements inside a function body (any depth: methods, nested functions, lambdas), in
    total and per module, split by what the statement's first name imports: a ``neuraluv``
    module, the standard library (``sys.stdlib_module_names``) or a third-party package.
    Module-level statements (including class bodies and ``if`` / ``try`` blocks at module
    level) are counted alongside. ``importlib.import_module`` / ``__import__`` calls are
    counted separately.
``--cycles``      the import graph among ``neuraluv`` modules (package ``__init__`` files are
    nodes named after the package). ``import a.b`` and ``from a.b import c`` give an edge to
    ``a.b`` (not when every imported name is a submodule), and to ``a.b.c`` when that is a
    module; a name that a package's ``__init__`` re-exports lazily (a module-level dict literal
    ``name -> "submodule"``, e.g. ``_EXPORTS`` / ``_LAZY`` / ``_WHERE``) gives an edge to that
    submodule too. No implicit edge from a module to its parent package. A module importing
    from itself (``from neuraluv.x import f`` inside ``neuraluv.x``) is listed, not an edge.
    Reported: strongly connected components (size > 1) of the module-level graph and of the
    graph with in-function imports added, every mutual pair ``A <-> B`` with the kind of each
    direction (``M`` module-level, ``F`` in-function), one shortest cycle through each module
    of each component, and the edges that point up the layers of
    ``trace_vertex_array.LAYERS`` (a lower layer importing a higher one).
"""
from __future__ import annotations

import argparse
import ast
import json
import os
import pathlib
import shutil
import statistics
import subprocess
import sys
import time
from collections import Counter, defaultdict, deque

ROOT = pathlib.Path(__file__).resolve().parents[1]
PKG = ROOT / "neuraluv"


def _env():
    env = dict(os.environ)
    env["PYTHONPATH"] = str(ROOT) + (os.pathsep + env["PYTHONPATH"] if env.get("PYTHONPATH") else "")
    env.setdefault("MPLBACKEND", "Agg")
    return env


# ---------------------------------------------------------------- timings


def _importtime_rows(stderr):
    rows = []
    for line in stderr.splitlines():
        if not line.startswith("import time:") or "self [us]" in line:
            continue
        self_us, cum_us, name = line[len("import time:"):].split("|", 2)
        rows.append((int(self_us), int(cum_us), name.rstrip()))
    return rows


def importtime(runs):
    subprocess.run([sys.executable, "-c", "import neuraluv"], env=_env(), cwd=ROOT, check=True)  # warm-up
    tops, totals = [], []
    for _ in range(runs):
        p = subprocess.run([sys.executable, "-X", "importtime", "-c", "import neuraluv"], env=_env(),
                           capture_output=True, text=True, cwd=ROOT, check=True)
        rows = _importtime_rows(p.stderr)
        tops.append(next(c for s, c, n in rows if n.strip() == "neuraluv"))
        totals.append(sum(s for s, c, n in rows))
    code = ("import sys, json, neuraluv; "
            "print(json.dumps({m: m in sys.modules for m in ('torch', 'scipy', 'numpy', 'matplotlib')}))")
    p = subprocess.run([sys.executable, "-c", code], env=_env(), capture_output=True, text=True, cwd=ROOT, check=True)
    return {"runs": runs, "neuraluv_cumulative_us_median": statistics.median(tops), "neuraluv_cumulative_us": tops,
            "all_imports_self_sum_us_median": statistics.median(totals), "loaded_by_import_neuraluv": json.loads(p.stdout)}


def _console_script():
    cand = pathlib.Path(sys.executable).parent / "neuraluv"
    return str(cand) if cand.exists() else shutil.which("neuraluv")


def help_time(runs):
    script = _console_script()
    if not script:
        return {"error": "no `neuraluv` console script next to sys.executable or on PATH"}
    subprocess.run([script, "--help"], env=_env(), capture_output=True, cwd=ROOT, check=True)  # warm-up, untimed
    walls = []
    for _ in range(runs):
        t = time.perf_counter()
        subprocess.run([script, "--help"], env=_env(), capture_output=True, cwd=ROOT, check=True)
        walls.append(time.perf_counter() - t)
    p = subprocess.run([sys.executable, "-X", "importtime", script, "--help"], env=_env(), capture_output=True,
                       text=True, cwd=ROOT, check=True)
    rows = _importtime_rows(p.stderr)
    names = [n.strip() for _, _, n in rows]
    heavy = {m: m in names for m in ("torch", "scipy", "numpy", "matplotlib")}
    via = {}
    for m in heavy:
        if heavy[m]:  # importtime lists a module after its children: the importers follow, less indented
            i = names.index(m)
            ind = len(rows[i][2]) - len(rows[i][2].lstrip())
            chain = [m]
            for _, _, n in rows[i + 1:]:
                k = len(n) - len(n.lstrip())
                if k < ind:
                    chain.append(n.strip())
                    ind = k
            via[m] = " <- ".join(chain)
    return {"script": script, "runs": runs, "median_s": statistics.median(walls), "walls_s": walls,
            "imported_by_help": heavy, "first_imported_via": via,
            "neuraluv_modules": sorted({n for n in names if n == "neuraluv" or n.startswith("neuraluv.")})}


# ---------------------------------------------------------------- the ast walk


def modules():
    """``{dotted name: path}`` of every module of the package (``__init__`` named after its package)."""
    out = {}
    for p in sorted(PKG.rglob("*.py")):
        rel = p.relative_to(ROOT).with_suffix("")
        parts = list(rel.parts)
        if parts[-1] == "__init__":
            parts = parts[:-1]
        out[".".join(parts)] = p
    return out


def _lazy_tables(mods):
    """``{package: {name: submodule}}`` from module-level dict literals of str -> str in ``__init__`` files."""
    out = {}
    for name, path in mods.items():
        if path.name != "__init__.py":
            continue
        table = {}
        for node in ast.parse(path.read_text()).body:
            value = node.value if isinstance(node, (ast.Assign, ast.AnnAssign)) else None
            if not isinstance(value, ast.Dict):
                continue
            for k, v in zip(value.keys, value.values):
                if (isinstance(k, ast.Constant) and isinstance(k.value, str) and isinstance(v, ast.Constant)
                        and isinstance(v.value, str) and f"{name}.{v.value}" in mods):
                    table[k.value] = f"{name}.{v.value}"
        if table:
            out[name] = table
    return out


class _Walker(ast.NodeVisitor):
    def __init__(self, modname, is_pkg):
        self.modname, self.is_pkg = modname, is_pkg
        self.depth = 0          # function nesting
        self.stmts = []         # (in_function, target module names, lineno, first top-level name)
        self.dynamic = 0

    def _func(self, node):
        self.depth += 1
        self.generic_visit(node)
        self.depth -= 1

    visit_FunctionDef = visit_AsyncFunctionDef = visit_Lambda = _func

    def visit_Import(self, node):
        names = [a.name for a in node.names]
        self.stmts.append((self.depth > 0, names, [], node.lineno, names[0].split(".")[0]))

    def visit_ImportFrom(self, node):
        if node.level:  # relative: resolve against this module's package
            base = self.modname.split(".")
            base = base if self.is_pkg else base[:-1]
            base = base[:len(base) - node.level + 1]
            mod = ".".join(base + ([node.module] if node.module else []))
        else:
            mod = node.module or ""
        self.stmts.append((self.depth > 0, [mod], [a.name for a in node.names], node.lineno, mod.split(".")[0]))

    def visit_Call(self, node):
        f = node.func
        if ((isinstance(f, ast.Attribute) and f.attr == "import_module")
                or (isinstance(f, ast.Name) and f.id in ("import_module", "__import__"))):
            self.dynamic += 1
        self.generic_visit(node)


def walk():
    mods = modules()
    lazy = _lazy_tables(mods)
    stdlib = set(sys.stdlib_module_names) | {"__future__"}
    per_mod = {}
    edges = defaultdict(set)  # (a, b) -> {"M", "F"}
    self_imports = []
    for name, path in mods.items():
        w = _Walker(name, path.name == "__init__.py")
        w.visit(ast.parse(path.read_text(), str(path)))
        c = Counter()
        for infn, targets, imported, line, top in w.stmts:
            kind = "neuraluv" if top == "neuraluv" else "stdlib" if top in stdlib else "third_party"
            c[("function" if infn else "module", kind)] += 1
            if top != "neuraluv":
                continue
            for t in targets:
                # the package itself only when a name is not a submodule (``from pkg import sub`` needs only sub)
                dests = {t} if t in mods and (not imported or any(f"{t}.{n}" not in mods for n in imported)) else set()
                for n in imported:
                    if f"{t}.{n}" in mods:
                        dests.add(f"{t}.{n}")
                    elif n in lazy.get(t, {}):
                        dests.add(lazy[t][n])
                for d in dests:
                    if d == name:  # a module importing from itself: reported, not an edge
                        self_imports.append(f"{name}:{line} ({'in function' if infn else 'module level'})")
                        continue
                    edges[(name, d)].add("F" if infn else "M")
        per_mod[name] = {"function": {k: c[("function", k)] for k in ("neuraluv", "third_party", "stdlib")},
                         "module": {k: c[("module", k)] for k in ("neuraluv", "third_party", "stdlib")},
                         "dynamic": w.dynamic}
    return mods, per_mod, edges, self_imports


def strongly_connected(nodes, adj):
    """Tarjan's strongly connected components (iterative)."""
    index, low, on, stack, out, counter = {}, {}, set(), [], [], [0]
    for root in nodes:
        if root in index:
            continue
        work = [(root, iter(sorted(adj.get(root, ()))))]
        index[root] = low[root] = counter[0]
        counter[0] += 1
        stack.append(root)
        on.add(root)
        while work:
            v, it = work[-1]
            for w in it:
                if w not in index:
                    index[w] = low[w] = counter[0]
                    counter[0] += 1
                    stack.append(w)
                    on.add(w)
                    work.append((w, iter(sorted(adj.get(w, ())))))
                    break
                if w in on:
                    low[v] = min(low[v], index[w])
            else:
                work.pop()
                if work:
                    low[work[-1][0]] = min(low[work[-1][0]], low[v])
                if low[v] == index[v]:
                    comp = []
                    while True:
                        w = stack.pop()
                        on.discard(w)
                        comp.append(w)
                        if w == v:
                            break
                    out.append(sorted(comp))
    return out


def _shortest_cycle(start, adj, allowed):
    """A shortest cycle ``start -> ... -> start`` inside ``allowed`` (BFS), or None."""
    if start in adj.get(start, ()):
        return [start, start]
    prev, q = {start: None}, deque([start])
    while q:
        v = q.popleft()
        for w in sorted(adj.get(v, ())):
            if w == start:
                path = [v]
                while prev[path[-1]] is not None:
                    path.append(prev[path[-1]])
                return path[::-1] + [start]
            if w in allowed and w not in prev:
                prev[w] = v
                q.append(w)
    return None


def cycles(mods, edges):
    out = {}
    for label, kinds in (("module_level", {"M"}), ("with_in_function", {"M", "F"})):
        adj = defaultdict(set)
        for (a, b), k in edges.items():
            if k & kinds:
                adj[a].add(b)
        comps = [c for c in strongly_connected(sorted(mods), adj) if len(c) > 1]
        out[label] = {"components": comps,
                      "shortest_cycles": {m: " -> ".join(_shortest_cycle(m, adj, set(c)) or [])
                                          for c in comps for m in c}}
    mutual = []
    for (a, b), k in sorted(edges.items()):
        if a < b and (b, a) in edges:
            mutual.append(f"{a} <-> {b}  ({a}->{b}: {''.join(sorted(k))}, {b}->{a}: {''.join(sorted(edges[(b, a)]))})")
    out["mutual_pairs"] = mutual
    sys.path.insert(0, str(pathlib.Path(__file__).parent))
    from trace_vertex_array import layer_of  # the same LAYERS map

    out["upward"] = [f"{a} ({layer_of(a):g}) -> {b} ({layer_of(b):g}): {''.join(sorted(k))}"
                     for (a, b), k in sorted(edges.items()) if layer_of(b) > layer_of(a)]
    return out


# ---------------------------------------------------------------- main


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    for f in ("importtime", "help-time", "imports", "cycles"):
        ap.add_argument(f"--{f}", action="store_true")
    ap.add_argument("--runs", type=int, default=5)
    ap.add_argument("--json")
    a = ap.parse_args(argv)
    every = not (a.importtime or a.help_time or a.imports or a.cycles)
    res = {}
    if every or a.importtime:
        r = res["importtime"] = importtime(a.runs)
        print(f"== import neuraluv ({r['runs']} runs): neuraluv cumulative median {r['neuraluv_cumulative_us_median']} us "
              f"{sorted(r['neuraluv_cumulative_us'])}; every import line's self time summed (incl. interpreter start-up "
              f"imports) median {r['all_imports_self_sum_us_median']} us; loaded: {r['loaded_by_import_neuraluv']}")
    if every or a.help_time:
        r = res["help_time"] = help_time(a.runs)
        if "error" in r:
            print("== neuraluv --help:", r["error"])
        else:
            print(f"== neuraluv --help ({r['script']}, {r['runs']} runs): median {r['median_s']:.3f} s "
                  f"[{', '.join(f'{x:.3f}' for x in sorted(r['walls_s']))}]; imported: {r['imported_by_help']}")
            for m, chain in r["first_imported_via"].items():
                print(f"  {chain}")
            print(f"  neuraluv modules imported ({len(r['neuraluv_modules'])}): {', '.join(r['neuraluv_modules'])}")
    if every or a.imports or a.cycles:
        mods, per_mod, edges, self_imports = walk()
    if every or a.imports:
        tot = Counter()
        for m in per_mod.values():
            for where in ("function", "module"):
                for k, v in m[where].items():
                    tot[(where, k)] += v
        fn_total = sum(v for (w, _), v in tot.items() if w == "function")
        mod_total = sum(v for (w, _), v in tot.items() if w == "module")
        res["imports"] = {"in_function_total": fn_total,
                          "in_function": {k: tot[("function", k)] for k in ("neuraluv", "third_party", "stdlib")},
                          "module_level_total": mod_total,
                          "module_level": {k: tot[("module", k)] for k in ("neuraluv", "third_party", "stdlib")},
                          "dynamic_import_calls": sum(m["dynamic"] for m in per_mod.values()),
                          "per_module": per_mod}
        print(f"== import statements in {len(mods)} modules: in function bodies {fn_total} "
              f"(neuraluv {tot[('function', 'neuraluv')]}, third-party {tot[('function', 'third_party')]}, "
              f"stdlib {tot[('function', 'stdlib')]}); module level {mod_total} "
              f"(neuraluv {tot[('module', 'neuraluv')]}, third-party {tot[('module', 'third_party')]}, "
              f"stdlib {tot[('module', 'stdlib')]}); importlib.import_module/__import__ calls "
              f"{res['imports']['dynamic_import_calls']}")
        print(f"  {'module':34s} {'in-fn':>5s} {'nuv':>4s} {'3rd':>4s} {'std':>4s} | {'top':>4s} {'nuv':>4s} {'3rd':>4s} "
              f"{'std':>4s}")
        for name in sorted(per_mod, key=lambda n: (-sum(per_mod[n]["function"].values()), n)):
            f, m = per_mod[name]["function"], per_mod[name]["module"]
            if not (sum(f.values()) or sum(m.values())):
                continue
            print(f"  {name:34s} {sum(f.values()):>5d} {f['neuraluv']:>4d} {f['third_party']:>4d} {f['stdlib']:>4d} | "
                  f"{sum(m.values()):>4d} {m['neuraluv']:>4d} {m['third_party']:>4d} {m['stdlib']:>4d}")
    if every or a.cycles:
        c = res["cycles"] = cycles(mods, edges)
        res["edges"] = {f"{x} -> {y}": "".join(sorted(k)) for (x, y), k in sorted(edges.items())}
        print(f"== import graph: {len(mods)} modules, {len(edges)} edges "
              f"({sum('M' in k for k in edges.values())} with a module-level import, "
              f"{sum(k == {'F'} for k in edges.values())} in-function only)")
        for label in ("module_level", "with_in_function"):
            comps = c[label]["components"]
            print(f"  cycles, {label.replace('_', ' ')} imports: {len(comps)} component(s)")
            for comp in comps:
                print(f"    [{len(comp)}] " + ", ".join(comp))
                for m in comp:
                    print(f"        {c[label]['shortest_cycles'][m]}")
        c["self_imports"] = self_imports
        print(f"  modules importing from themselves (not edges): {', '.join(self_imports) or '-'}")
        print(f"  mutual pairs (M module-level, F in-function): {len(c['mutual_pairs'])}")
        for p in c["mutual_pairs"]:
            print("    " + p)
        print(f"  upward imports (into a higher layer of trace_vertex_array.LAYERS): {len(c['upward'])}")
        for p in c["upward"]:
            print("    " + p)
    if a.json:
        with open(a.json, "w") as fh:
            json.dump(res, fh, indent=1, default=list)


if __name__ == "__main__":
    main()
