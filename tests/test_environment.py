"""Data registry, derived compact charts, packing, and the environment files."""
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def test_environment_yml_matches_pyproject():
    import tomllib
    import yaml

    pp = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    extras = pp["optional-dependencies"]
    wanted = set(pp["dependencies"]).union(*(extras[e] for e in ("render", "sweep", "fast", "test", "docs")))
    env = yaml.safe_load((ROOT / "environment.yml").read_text())
    pip = [d for d in env["dependencies"] if isinstance(d, dict)][0]["pip"]
    pip = [p for p in pip if not p.startswith("-e")]
    assert set(pip) == wanted  # same names and the same pins
    assert "torch==2.13.0" in pp["dependencies"]
