"""The package's shape: the library stands without the paper's harness and the optional extras, imports point
down without a circle, modules stay readable."""
import ast
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
LIB = ROOT / "neuraluv"
OPTIONAL = ("pyvista", "vtk", "plotly", "dask", "distributed", "mouette", "neuraluv_paper")

#: A preamble that makes the optional packages (and the harness) unimportable in a subprocess.
BLOCK = f"""
import sys
class _Block:
    def find_spec(self, name, path=None, target=None):
        if name.split('.')[0] in {OPTIONAL!r}:
            raise ModuleNotFoundError(f"No module named {{name!r}}", name=name)
sys.meta_path.insert(0, _Block())
"""


def _modules(root=LIB, package="neuraluv"):
    for p in sorted(root.rglob("*.py")):
        parts = p.relative_to(root.parent).with_suffix("").parts
        yield ".".join(parts[:-1] if parts[-1] == "__init__" else parts), p


def _run(code):
    return subprocess.run([sys.executable, "-c", BLOCK + code], capture_output=True, text=True, cwd=ROOT, timeout=300)


def test_every_library_module_imports_without_the_extras_and_the_harness():
    names = [m for m, _ in _modules() if not m.endswith("__main__")]
    r = _run("import importlib\n" + "\n".join(f"importlib.import_module({m!r})" for m in names))
    assert r.returncode == 0, r.stderr[-2000:]


def test_the_library_never_imports_the_harness():
    """Only the CLI's ``bench`` forwarder may reach ``neuraluv_paper`` (and it degrades to a hint)."""
    offenders = []
    for mod, path in _modules():
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            names = [a.name for a in node.names] if isinstance(node, ast.Import) else \
                [node.module or ""] if isinstance(node, ast.ImportFrom) else []
            if any(n.split(".")[0] == "neuraluv_paper" for n in names) and mod != "neuraluv.cli.bench":
                offenders.append(mod)
    assert not offenders, offenders


def test_bench_without_the_harness_is_a_one_line_hint():
    r = _run("from neuraluv.cli import main; raise SystemExit(main(['bench', 'compact', '--quick']))")
    assert r.returncode == 2, r.stderr
    assert r.stderr.count("\n") == 1 and "neuraluv[paper]" in r.stderr and "Traceback" not in r.stderr


def test_a_missing_extra_is_a_one_line_error():
    r = _run("from neuraluv.errors import missing_extra\n"
             "try:\n    import pyvista\nexcept ModuleNotFoundError as e:\n    print(missing_extra(e))")
    assert r.stdout.strip() == 'this needs the optional package pyvista: pip install "neuraluv[render]"'


def _import_graph(root, package):
    """Module -> neuraluv modules it imports (at module level or inside functions)."""
    mods = dict(_modules(root, package))
    graph = {}
    for mod, path in mods.items():
        deps = set()
        pkg = mod if path.name == "__init__.py" else mod.rsplit(".", 1)[0]
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.ImportFrom):
                base = node.module or ""
                if node.level:
                    base = ".".join(pkg.split(".")[:len(pkg.split(".")) - node.level + 1] + ([base] if base else []))
                for a in node.names:
                    full = f"{base}.{a.name}"
                    deps.add(full if full in mods else base)
            elif isinstance(node, ast.Import):
                deps.update(a.name for a in node.names)
        graph[mod] = {d for d in deps if d in mods and d != mod}
    return graph


def _cycles(graph):
    """Strongly connected components of more than one module (data_scripts/import_graph.py's Tarjan)."""
    import importlib.util

    spec = importlib.util.spec_from_file_location("import_graph", ROOT / "data_scripts" / "import_graph.py")
    tool = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(tool)
    return [c for c in tool.strongly_connected(sorted(graph), graph) if len(c) > 1]


@pytest.mark.parametrize("package", ["neuraluv", "neuraluv_paper"])
def test_no_import_circle(package):
    graph = _import_graph(ROOT / package, package)
    # a module importing its own package's __init__ (settings, lazy re-exports) is not a circle of ideas
    graph = {m: {d for d in ds if not (m.startswith(d + ".") and (ROOT / (d.replace(".", "/") + "/__init__.py")).is_file())}
             for m, ds in graph.items()}
    assert not _cycles(graph), _cycles(graph)


def test_cycle_finder_finds_a_circle():
    assert _cycles({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": set()}) == [["a", "b", "c"]]


@pytest.mark.parametrize("root", [LIB, ROOT / "neuraluv_paper"], ids=["neuraluv", "neuraluv_paper"])
def test_no_module_over_600_lines(root):
    long = {p.relative_to(ROOT).as_posix(): n for p in root.rglob("*.py")
            if (n := len(p.read_text(encoding="utf-8").splitlines())) > 600}
    assert not long, long


def test_import_neuraluv_loads_neither_torch_nor_scipy():
    r = subprocess.run([sys.executable, "-c", "import sys, neuraluv; print('torch' in sys.modules, 'scipy' in sys.modules)"],
                       capture_output=True, text=True, cwd=ROOT, timeout=120)
    assert r.stdout.split() == ["False", "False"], r.stdout + r.stderr


def test_the_command_line_parser_loads_no_numerics():
    """``neuraluv --help`` builds every subcommand's parser without numpy, scipy or torch (it answers in a blink)."""
    r = subprocess.run([sys.executable, "-c", "import sys; from neuraluv.cli import build_parser; build_parser([]); "
                        "print(sorted(m for m in ('numpy', 'scipy', 'torch', 'shapely') if m in sys.modules))"],
                       capture_output=True, text=True, cwd=ROOT, timeout=120)
    assert r.stdout.strip() == "[]", r.stdout + r.stderr


def test_a_command_needing_a_missing_extra_refuses_before_any_work(tmp_path):
    from conftest import write_mesh
    from neuraluv.datasets import sphere

    write_mesh(tmp_path / "s.obj", *sphere(1))
    out = tmp_path / "s_uv.obj"
    r = _run(f"from neuraluv.cli import main; raise SystemExit(main(['atlas', {str(tmp_path / 's.obj')!r}, '-o', "
             f"{str(out)!r}, '--renders', {str(tmp_path / 'r')!r}, '--preset', 'test']))")
    assert r.returncode == 2 and 'pip install "neuraluv[render]"' in r.stderr, r.stderr
    assert not out.exists()  # refused before the atlas was built, not after writing it
