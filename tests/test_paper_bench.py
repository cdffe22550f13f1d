"""The benchmark runners (``neuraluv bench``): quick-mode smoke with real content checks."""
import json
from pathlib import Path

import numpy as np
import pytest
import torch

from neuraluv import datasets
from neuraluv.cli import main
from neuraluv.datasets import sphere
from neuraluv_paper.bench import paper_values as PV
from neuraluv_paper.bench import provenance as tables

#: every runner is a benchmark: ``make test-fast`` leaves them out
pytestmark = pytest.mark.slow


@pytest.fixture(autouse=True)
def one_thread():
    """Tiny networks run faster on one thread (and leave the other core to the rest of the suite)."""
    n = torch.get_num_threads()
    torch.set_num_threads(1)
    yield
    torch.set_num_threads(n)


# ------------------------------------------------------------------ tables / paper values

def test_number_formatting_matches_the_paper():
    assert tables.fmt_num(1.47e9) == "1.47×10^9"
    assert tables.fmt_num(7.86e7) == "7.86×10^7"
    assert tables.fmt_num(30909.10) == "30909.10"
    assert tables.fmt_pct(13.56) == "13.56%"
    assert tables.fraction(42, 47, pct=True) == "42/47 (89.4%)"
    assert tables.with_paper("4.21", "4.14") == "4.21 [4.14]"
    assert "†" in tables.grey("8.98") and "color:gray" in tables.grey("8.98")
    assert tables.plain(tables.grey("8.98")) == "8.98†"


PAPER_TEX = sorted((Path(__file__).resolve().parents[2] / "shared" / "paper").glob("*.txt"))


def _latex_number(cell):
    """A number as the paper's LaTeX prints it (``\\inv{$1.47{\\times}10^9$}``, ``13.56\\%``); None for a dash."""
    import re

    c = re.sub(r"\\(inv|textbf)\{(.*)\}", r"\2", cell.strip()).replace("$", "").replace("\\%", "")
    if c.startswith("---"):
        return None
    m = re.fullmatch(r"([\d.]+)\{\\times\}10\^(\d+)", c)
    return float(m[1]) * 10 ** int(m[2]) if m else float(c)


@pytest.mark.skipif(not PAPER_TEX, reason="the paper's LaTeX is not next to the repository")
def test_paper_values_are_the_latex_tables_numbers():
    """Every number of ``paper_values.COMPACT_PRELIM`` is read back from the paper's ``tab:compact_prelim``, row by row."""
    import re

    text = PAPER_TEX[0].read_text(encoding="utf-8")
    block = text[text.index(r"\label{tab:compact_prelim}"):]
    block = block[:block.index(r"\end{tabular}")]
    names = {"LSCM": "lscm", "ARAP": "arap", "SLIM-1k": "slim-1k", "BFF": "bff", "Ours": "neural",
             "OptCuts (re-cut)": "optcuts"}
    rows = {}
    for line in block.splitlines():
        cells = [c.strip() for c in line.rstrip("\\ ").split("&")]
        if len(cells) == 7 and cells[1] in names:
            vals = [_latex_number(c) for c in cells[2:]]
            rows[(cells[0].lower(), names[cells[1]])] = None if vals[0] is None else dict(
                zip(("esd", "conformal", "area", "flip_percent", "time"), vals))
    assert set(rows) == set(PV.COMPACT_PRELIM), set(rows) ^ set(PV.COMPACT_PRELIM)
    for key, want in rows.items():
        got = PV.COMPACT_PRELIM[key]
        assert (got is None) == (want is None), key
        if want is not None:
            assert got == pytest.approx(want, rel=1e-12), (key, got, want)
    assert re.search(r"13\.56", block)  # the parser saw the Hand rows


def test_rowlog_resume_skips_finished_keys(tmp_path):
    log = tables.RowLog(tmp_path / "rows.jsonl")
    calls = []
    log.run(("m", "a", {"x": 1}), lambda: calls.append(1) or {"v": 1.0})
    again = tables.RowLog(tmp_path / "rows.jsonl", resume=True)
    row = again.run(("m", "a", {"x": 1}), lambda: calls.append(2) or {"v": 2.0})
    assert row == {"v": 1.0} and calls == [1] and again.skipped == 1
    # a different config is a different row
    again.run(("m", "a", {"x": 2}), lambda: calls.append(3) or {"v": 3.0})
    assert calls == [1, 3]
    # without resume the log starts empty
    assert not tables.RowLog(tmp_path / "rows.jsonl").done(("m", "a", {"x": 1}))


def test_machine_line_names_the_machine():
    line = tables.machine_line(device="cpu")
    assert "torch" in line and "cores" in line and "commit" in line and "UTC" in line


def test_cli_lists_every_benchmark(capsys):
    assert main(["bench", "--help"]) == 0
    out = capsys.readouterr().out
    for name in ("compact", "failure-modes", "ablation", "pareto", "charts", "ntk", "speed", "repair", "generated"):
        assert name in out


# ------------------------------------------------------------------ runners (quick mode)

def test_compact_quick_rows_statuses_and_resume(tmp_path):
    from neuraluv_paper.bench.compact import bench

    res = bench(quick=True, output=tmp_path, figures=False, show_progress=False)
    rows = {(r["mesh"], r["method"], r["mode"]): r for r in res.rows}
    # 6 methods on each of 2 meshes + 4 per-component rows for the 3-component chart
    assert len(res.rows) == 16
    assert rows[("components", "lscm", "whole")]["status"] == "init fail"
    assert rows[("components", "lscm", "per component")]["status"] == "ok"
    assert rows[("glove", "neural", "whole")]["status"] == "neural" and rows[("glove", "neural", "whole")]["flips"] == 0
    assert rows[("glove", "optcuts", "whole")]["status"] in ("unavailable", "ok", "error")
    md = (tmp_path / "compact_prelim.md").read_text()
    assert "| Mesh | Method |" in md and "Machine:" in md and "Produced by" in md and "init fail" in md
    csv = (tmp_path / "compact_prelim.csv").read_text().splitlines()
    assert csv[0].startswith("mesh,mode,method") and len(csv) == 17
    again = bench(quick=True, output=tmp_path, figures=False, show_progress=False, resume=True)
    # every finished row is reused, except "unavailable" ones (an optional binary may have been installed since)
    assert again.skipped == sum(r["status"] != "unavailable" for r in res.rows) >= 14
    assert [r["esd"] for r in again.rows if r["status"] != "unavailable"] == \
        [r["esd"] for r in res.rows if r["status"] != "unavailable"]


def test_resume_recomputes_unavailable_rows(tmp_path, monkeypatch):
    from neuraluv_paper.bench.compact import bench

    monkeypatch.setenv("NEURALUV_BFF", str(tmp_path / "missing"))
    first = bench(["disk"], ["lscm", "bff-cli"], quick=True, output=tmp_path, figures=False, show_progress=False)
    assert [r["status"] for r in first.rows] == ["ok", "unavailable"]
    calls = []
    import neuraluv_paper.bench.compact as runner

    real = runner.run_baseline
    monkeypatch.setattr(runner, "run_baseline", lambda m, *a, **k: calls.append(m) or real(m, *a, **k))
    again = bench(["disk"], ["lscm", "bff-cli"], quick=True, output=tmp_path, figures=False, show_progress=False,
                  resume=True)
    assert calls == ["bff-cli"] and again.skipped == 1


def test_compact_greys_flipped_distortion_and_prints_paper_values(tmp_path, monkeypatch):
    """A folding method's distortion is greyed; a paper mesh gets the paper's numbers beside ours."""
    from neuraluv_paper.bench import compact as bench_compact

    def fake_load(names, quick=False):  # the curled glove makes ARAP fold; call it "camel"
        V, F = datasets.glove(res=2, curl=2.5, finger_length=7)
        return [("camel", V, F)]

    monkeypatch.setattr(bench_compact, "load_meshes", fake_load)
    res = bench_compact.bench(["camel"], ["lscm", "arap"], output=tmp_path, figures=False, show_progress=False)
    arap = next(r for r in res.rows if r["method"] == "arap")
    assert arap["flips"] > 0
    md = res.markdown
    assert "[30909.10†]" in tables.plain(md)  # the paper greys it too
    assert "[0.22%]" in md and "[406.22†]" in tables.plain(md)  # LSCM and ARAP on Camel, as published
    arap_line = next(line for line in md.splitlines() if "| ARAP |" in line)
    assert arap_line.count("color:gray") >= 3  # E_SD, conformal, area of the folded map
    lscm_line = next(line for line in md.splitlines() if "| LSCM |" in line)
    assert "**" in lscm_line.split("[")[0]  # the only valid fixed-chart map is the best: bold


def test_failure_modes_quick(tmp_path):
    from neuraluv_paper.bench.failure_modes import bench

    res = bench(quick=True, output=tmp_path, neural=False, show_progress=False)
    cells = {(r["mesh"], r["method"]): r["cell"] for r in res.rows}
    assert cells[("components", "slim-20")] == "init fail" and cells[("components", "slim-1k")] == "init fail"
    assert cells[("components", "bff")].startswith("E_SD=")
    # glove is a single disk: SLIM runs and is flip-free (an E_SD cell), never an init failure
    assert cells[("glove", "slim-1k")].startswith("E_SD="), cells[("glove", "slim-1k")]
    assert "| components | 3/3 |" in res.markdown and "| glove | 1/1 |" in res.markdown


def test_ablation_quick_reports_invalid_attempt_and_fallback(tmp_path):
    from neuraluv_paper.bench.ablation import bench

    res = bench(variants=["full", "random init"], quick=True, output=tmp_path, show_progress=False)
    s = {x["variant"]: x for x in res.extra["summary"]}
    assert s["full"]["valid"] == 1 and s["full"]["fallback_charts"] == 0
    ri = s["random init"]
    assert ri["valid"] == 0 and ri["flip_percent"] > 0 and ri["min_det"] < 0  # the invalid neural attempt
    assert ri["fallback_charts"] == ri["charts"] == 1  # ...while the returned map is the marked fallback
    row = next(r for r in res.rows if r["variant"] == "random init")
    assert row["status"] == "fallback" and row["flips"] == 0  # the map actually returned is valid
    assert "[50.60%]" in res.markdown and "[invalid]" in res.markdown and "1/1" in res.markdown
    assert "brackets average Hand, Bob, Camel; this table averages glove" in res.markdown  # not the paper's charts

def test_ablation_seeds_report_mean_and_spread_over_seeds(tmp_path):
    from neuraluv_paper.bench.ablation import bench

    res = bench(variants=["full", "k=0"], quick=True, seeds=[0, 1], output=tmp_path, show_progress=False)
    assert sorted({(r["variant"], r["seed"]) for r in res.rows}) == [("full", 0), ("full", 1), ("k=0", 0), ("k=0", 1)]
    s = {x["variant"]: x for x in res.extra["summary"]}["full"]
    per_seed = [r["neural_esd"] for r in res.rows if r["variant"] == "full"]
    assert np.isclose(s["esd"], np.mean(per_seed)) and np.isclose(s["esd_sd"], np.std(per_seed, ddof=1))
    assert "seeds 0, 1" in res.markdown and " ± " in res.markdown



def test_charts_quick_strata_and_denominators(tmp_path):
    from neuraluv_paper.bench.charts import FIRST_LABEL, SMALL_STRATA, bench, select_charts, stratum, subdivided_charts

    res = bench(quick=True, output=tmp_path, show_progress=False, baselines=("bff",), k0=True)
    neural = [r for r in res.rows if r["method"] == "neural"]
    strat = [r for r in neural if r["stratum"] != FIRST_LABEL]
    assert len(strat) == 6 and len({r["stratum"] for r in strat}) == 2
    first = [r for r in neural if r["stratum"] == FIRST_LABEL]  # the first-N sweep: the first 3 charts, disk-like ones
    assert 1 <= len(first) <= 3 and all(r["source"] == "sphere" for r in first)
    summ = next(s for s in res.extra["summary"] if s["method"] == "neural" and s["subset"] == "all")
    assert summ["tried"] == 6 and f"{summ['valid']}/6 (" in res.markdown  # the stratified set excludes the sweep
    assert "xatlas first-3" in res.markdown and "stratified, all" in res.markdown
    assert "paper: Xatlas stratified" in res.markdown and "42/47 (89.4%)" in res.markdown
    assert "280/287" in res.markdown  # the sweep's finding, against the paper's
    k0 = [r for r in res.rows if r["method"] == "neural-k0"]  # k=0 on the stratified charts only
    assert len(k0) == 6 and {r["chart"] for r in k0} == {r["chart"] for r in strat}
    assert "k=16 solves at least as many charts validly as k=0" in res.markdown
    # --from-log writes the table from the log alone; a job missing there is named, not computed
    lines = (tmp_path / "rows.jsonl").read_text().splitlines()
    (tmp_path / "rows.jsonl").write_text("\n".join(lines[:-1]) + "\n")
    again = bench(quick=True, output=tmp_path, show_progress=False, baselines=("bff",), k0=True, resume=True, from_log=True)
    assert len(again.rows) == len(res.rows) - 1 and "Not run (written from the log" in again.markdown
    # the selection spreads a budget over strata and hands leftovers on
    pool = [{"disk": True, "faces": f, "source": "s", "chart": i} for i, f in enumerate([20, 30, 40, 200, 5000])]
    chosen = select_charts(pool, 4, SMALL_STRATA)
    assert len(chosen) == 4 and {c["stratum"] for c in chosen} == {"tens", "hundreds", "thousands"}
    assert stratum(12000) == "tens of thousands" and stratum(150000) == "hundreds of thousands"
    # subdivided copies only above 10,000 faces, and only of disk-like charts of >= 1,000 faces
    pool += [{"disk": False, "faces": 3000, "source": "s", "chart": 9}]
    sub = subdivided_charts(pool)
    assert [(c["chart"], c["faces"]) for c in sub] == [("4/s1", 20000), ("4/s2", 80000)]


def test_pareto_quick(tmp_path):
    from neuraluv_paper.bench.pareto import bench

    res = bench(["glove"], [5, 15], quick=True, output=tmp_path, show_progress=False)
    s = res.extra["summary"]
    assert [x["iterations"] for x in s] == [5, 15] and all(x["n"] == 1 for x in s)
    assert "1/1" in res.markdown and (tmp_path / "pareto.png").stat().st_size > 1000


def test_generated_quick_counts_coverage_routes_and_marks_blender_not_run(tmp_path, monkeypatch):
    from neuraluv_paper.bench.generated import bench

    monkeypatch.setenv("NEURALUV_BPY_PYTHON", str(tmp_path / "no-python"))  # as in CI: no bpy
    res = bench(1, quick=True, output=tmp_path, show_progress=False, device="cpu")
    ours = [r for r in res.rows if r["method"] == "ours"][0]
    assert ours["status"] == "ok" and ours["coverage"] == 1.0 and ours["flips"] == 0
    assert abs(ours["neural_share"] + ours["exact_share"] + ours["fallback_share"] - 1) < 1e-9
    assert {r["status"] for r in res.rows if r["method"] != "ours"} == {"unavailable"}
    verdicts = {claim: holds for claim, holds, _ in res.findings}
    assert verdicts["the full atlas path covers every repaired face with zero local flips"] is True
    assert any(holds is None and "Blender" in claim for claim, holds, _ in res.findings)
    assert (tmp_path / "amara_coverage_validity.md").exists() and (tmp_path / "amara_blender_methods.md").exists()


def test_generated_sweep_takes_the_first_n_assets_even_when_the_folder_holds_more(tmp_path, monkeypatch):
    import types

    import neuraluv_paper.bench.generated as runner
    from neuraluv_paper.bench.generated import _sweep

    src = tmp_path / "cache" / "assets"
    src.mkdir(parents=True)
    for i in range(5):  # left by an earlier, larger sweep
        (src / f"gen_{i:04d}.obj").write_text("v 0 0 0\n")
    seen = {}

    def fake_sweep(inputs, out_dir, **kw):
        seen["inputs"] = [Path(p).name for p in inputs]
        return types.SimpleNamespace(summary={"tried": len(inputs)})

    monkeypatch.setattr(runner, "sweep", fake_sweep)
    assert _sweep(tmp_path, 2, "test", 1, True, True) == {"tried": 2}
    assert seen["inputs"] == ["gen_0000.obj", "gen_0001.obj"]


def test_cli_bench_runs_and_resumes(tmp_path, capsys):
    args = ["bench", "failure-modes", "--quick", "--no-neural", "--meshes", "components", "-o", str(tmp_path), "--quiet"]
    assert main(args) == 0
    out = capsys.readouterr().out
    assert "init fail" in out and "Machine:" in out
    first = [json.loads(line) for line in (tmp_path / "rows.jsonl").read_text().splitlines()]
    assert len(first) == 4
    kept = sum(r["row"]["status"] != "unavailable" for r in first)  # unavailable rows (no OptCuts built) are retried
    assert main(args + ["--resume"]) == 0
    assert f"{kept} row(s) taken from the resume log" in capsys.readouterr().out
    rows = [json.loads(line) for line in (tmp_path / "rows.jsonl").read_text().splitlines()]
    assert {(r["key"], r["row"]["status"]) for r in rows} == {(r["key"], r["row"]["status"]) for r in first}
    failed = [r["row"] for r in rows if r["row"]["status"] == "init fail"]
    assert failed and all(np.isnan(float(r["esd"])) for r in failed)  # a method that made no map has no number


def test_unknown_benchmark_method_is_a_user_error(tmp_path, capsys):
    assert main(["bench", "compact", "--quick", "--methods", "nope", "-o", str(tmp_path)]) == 2
    assert "unknown method" in capsys.readouterr().err


def test_speed_quick_writes_the_table_with_floor_split_and_slim(tmp_path):
    from neuraluv_paper.bench.speed import bench

    res = bench(["glove"], ["fast"], quick=True, output=tmp_path, show_progress=False)
    (row,) = res.rows
    assert row["floor_ms"] > 0 and row["per_it_ms"] >= row["floor_ms"] * 0.5
    parts = sum(row[f"{k}_ms"] for k in ("forward", "backward", "objective", "optimiser", "bookkeeping"))
    assert parts == pytest.approx(row["per_it_ms"], rel=1e-6)  # the split adds up to the per-iteration time
    assert row["flips"] == 0 and row["slim1k_s"] > 0 and row["ratio_slim1k"] > 0
    for f in ("speed.csv", "speed.md", "speed.png"):
        assert (tmp_path / f).stat().st_size > 100
    assert "× SLIM-1k" in res.markdown and "Machine:" in (tmp_path / "speed.md").read_text()
    # every row is logged when it is finished; --resume reuses it instead of timing it again
    assert len((tmp_path / "rows.jsonl").read_text().splitlines()) == 1
    again = bench(["glove"], ["fast"], quick=True, output=tmp_path, show_progress=False, resume=True)
    assert again.rows[0]["per_it_ms"] == row["per_it_ms"] and again.rows[0]["esd"] == row["esd"]
    assert len((tmp_path / "rows.jsonl").read_text().splitlines()) == 1


def test_grown_disk_is_a_disk_of_about_the_asked_size():
    from neuraluv.topology import is_disk_like, submesh
    from neuraluv_paper.bench.speed import grown_disk

    V, F = sphere(4)
    for n in (100, 1500):
        f = grown_disk(V, F, n)
        vi, Fl = submesh(F, f)
        assert is_disk_like(V[vi], Fl)[0] and n <= len(f) < 3 * n


def test_bench_atlas_quality_cli_writes_the_table(tmp_path, capsys):
    from neuraluv.cli import main

    rc = main(["bench", "atlas-quality", "--quick", "--meshes", "glove", "--quiet", "-o", str(tmp_path)])
    out = capsys.readouterr().out
    assert rc == 0 and "| glove |" in out and "ours + tight" in out
    md = (tmp_path / "atlas_quality.md").read_text()
    assert "Acceptance" in md and "xatlas (own charts + packer)" in md


def test_bench_atlas_quality_generated_from_picks_the_seeds():
    from argparse import Namespace

    from neuraluv.datasets.generated import generated_asset
    from neuraluv_paper.bench.atlas_quality import _assets

    got = _assets(Namespace(meshes=["glove"], quick=False, generated=2, generated_from=7))
    assert [a[0] for a in got] == ["glove", "generated-7", "generated-8"]
    assert np.array_equal(got[2][2], generated_asset(8)[1])


def test_bench_repair_quick(tmp_path):
    from neuraluv_paper.bench.repair import bench

    out = bench(output=tmp_path, quick=True, preset="fast", mouette=False, show_progress=False)
    gen = [r for r in out.rows if r["case"] != "as produced"]
    assert gen and all(r["fixed"] for r in gen), [(r["case"], r["fixed"]) for r in gen]
    fold = [r for r in gen if r["case"] == "local fold"][0]
    # the glove is small (882 faces): judge the repaired region against the damaged one, not the whole island
    changed = round((1 - fold["bit_identical_island"]) * fold["faces"])
    assert changed <= 4 * fold["damage"]["faces"], (changed, fold["damage"])
    assert fold["esd_ratio"] <= 1.05
    # the faces kept as supplied are measured too: unchanged bits give the undamaged E_SD where the damage did not reach
    assert all(r["esd_kept_repaired"] is not None for r in gen if r["bit_identical_island"] > 0)
    assert (tmp_path / "repair.md").exists() and (tmp_path / "repair.csv").exists()


def test_bench_repair_explains_a_rise_in_esd():
    from neuraluv_paper.bench.repair import _markdown

    row = {"layout": "atlas", "case": "vertex noise", "faces": 10, "flips_before": 2, "overlaps_before": 0,
           "fixed": True, "flips_after": 0, "overlaps_after": 0, "bit_identical_island": 0.9, "bit_identical_all": 0.9,
           "esd_undamaged": 4.0, "esd_repaired": 40.0, "esd_ratio": 10.0, "esd_kept_undamaged": 4.0,
           "esd_kept_repaired": 44.0, "time_s": 0.1, "steps": "untangle+polish", "scaled": False, "repacked": False}
    md = _markdown([row], [])
    assert "atlas vertex noise ×10.000; over the faces kept as supplied (90.0% of the island) 4.000 → 44.000" in md
    assert "above ×1.05" not in _markdown([{**row, "esd_repaired": 4.1, "esd_ratio": 1.025}], [])
    # a case mouette does not take reads "—"; without mouette the column says so
    assert "| — |" in md and "unavailable" not in md
    assert "| not installed |" in _markdown([row], [], mouette_ran=False)


@pytest.mark.slow
def test_atlas_speed_reports_stages_xatlas_and_two_processes_at_once(tmp_path):
    """``bench speed --atlas``: per-stage times from each command's report, xatlas's own atlas of the same mesh in
    the same run, and the first asset run as two concurrent processes (issue 28)."""
    from neuraluv_paper.bench.speed_atlas import STAGES, atlas_timing

    out = atlas_timing(meshes=[], n_generated=1, output=tmp_path, quick=True, argv=["bench", "x"],
                       show_progress=False, extra=("--preset", "test", "--pack-trials", "1"))
    row = out.rows[0]
    assert row["ok"] and all(row["t_" + k] >= 0 for k in STAGES) and row["t_io"] > 0
    assert row["xatlas_s"] > 0
    conc = [r for r in out.rows if r["kind"] == "concurrent"]
    assert len(conc) == 1 and conc[0]["ok"] and conc[0]["wall_s"] > 0
    text = (tmp_path / "atlas.md").read_text()
    assert "xatlas s (charts + pack)" in text and "Two at once" in text
    assert 0 < row["utilisation"] < 1 and 0 < row["xatlas_utilisation"] < 1  # one measure, on the layouts read back
    assert "Blender s (unwrap + pack; process)" in text  # Blender's atlas of the same mesh, or one line saying why not
    from neuraluv_paper.baselines.external import blender_python

    if blender_python() is None:
        assert "Blender not run on 1 of 1 assets — unavailable: Blender's bpy module not found" in text
    else:
        assert row["blender_status"] == "ok" and row["blender_pack_s"] > 0 and 0 < row["blender_utilisation"] < 1
