"""Numeric rules for the claims checklist: the paper's number, ours, a stated tolerance and direction, a verdict.

A runner's findings (``results/*/*.findings.json``) say whether a claim holds
by its own test, often a category ("BFF solves Bob": ok / not ok). This module
re-reads the *numbers* behind a claim from the committed CSV beside its report
(and the paper's published values, :mod:`neuraluv_paper.bench.paper_values`)
and compares them by an explicit rule (:class:`Check`): e.g. "ours within ±5%
of the paper's E_SD" or "k=16's median E_SD higher than k=0's by more than 1%".
A claim holds when all its checks pass. A claim without a rule here is a
category match only and is labelled **qualitative** on the claims page.

Rules are looked up by the report a claim came from and the start of its text
(:data:`RULES`); each rule reads the CSV of the claim's own report folder, so a
subset run (``results/ablation/paper-camel-1k/``) is judged on its own numbers.
"""
from __future__ import annotations

import csv
import math
from dataclasses import dataclass
from pathlib import Path

__all__ = ["Check", "RULES", "checks_for"]

_OPS = {"≈": "within", ">": "higher than", "<": "lower than", "≥": "at least", "≤": "at most"}


def _fmt(x):
    if x is None or (isinstance(x, float) and math.isnan(x)):
        return "n/a"
    if isinstance(x, str):
        return x
    if math.isinf(x):
        return "∞"
    if x == int(x) and abs(x) < 1e5:
        return f"{int(x)}"
    a = abs(x)
    if a and (a >= 1e5 or a < 1e-3):
        return f"{x:.3g}"
    return f"{x:.4g}" if a < 10 else f"{x:.2f}"


@dataclass(frozen=True)
class Check:
    """One numeric comparison of a claim.

    Parameters
    ----------
    what : str
        The quantity, e.g. ``"Bob / BFF E_SD"``.
    ours : float
        Our committed number (NaN: not measured, e.g. an init failure; the check fails).
    op : {"≈", ">", "<", "≥", "≤"}
        The direction. With ``tol`` as a fraction of ``|ref|`` (or in the
        quantity's units when ``absolute``): ``≈`` ``|ours − ref| ≤ tol``;
        ``>`` ``ours > ref + tol`` (higher by more than tol); ``<``
        ``ours < ref − tol``; ``≥`` ``ours ≥ ref − tol``; ``≤`` ``ours ≤ ref + tol``.
    ref : float
        What ours is compared with: the paper's number or another of ours.
    ref_name : str
        ``"paper"`` or a label for another of our numbers (``"k=0"``).
    tol : float
    absolute : bool
    paper : float, optional
        The paper's number, printed when ``ref`` is not it.
    name : str
        What ``ours`` is, when it is not simply our result (``"BFF"`` compared with ``"ours (neural)"``).

    Examples
    --------
    >>> c = Check("Bob / BFF E_SD", 4.37, "≈", 14.04, tol=0.05)
    >>> c.ok, c.render()
    (False, 'Bob / BFF E_SD: paper 14.04, ours 4.37; rule |ours − paper| ≤ 5% of paper → fails')
    >>> Check("median E_SD", 4.01, ">", 4.00, "k=0", tol=0.01).ok   # higher, but not by 1%
    False
    """

    what: str
    ours: float
    op: str
    ref: float
    ref_name: str = "paper"
    tol: float = 0.0
    absolute: bool = False
    paper: float | None = None
    name: str = "ours"

    @property
    def margin(self):
        return self.tol if self.absolute else self.tol * abs(self.ref)

    @property
    def ok(self):
        o, r, m = float(self.ours), float(self.ref), self.margin
        if math.isnan(o) or math.isnan(r):
            return False
        return {"≈": abs(o - r) <= m if math.isfinite(o - r) else o == r, ">": o > r + m, "<": o < r - m,
                "≥": o >= r - m, "≤": o <= r + m}[self.op]

    def rule(self):
        """The rule in words, e.g. ``"ours > k=0 by more than 1%"``."""
        r, o = self.ref_name, self.name
        t = (f"{_fmt(self.tol)}" if self.absolute else f"{100 * self.tol:.3g}% of {r}")
        if self.op == "≈":
            return f"|{o} − {r}| ≤ {t}"
        if not self.tol:
            return f"{o} {self.op} {r}"
        return {">": f"{o} > {r} by more than {t}", "<": f"{o} < {r} by more than {t}",
                "≥": f"{o} ≥ {r} − {t}", "≤": f"{o} ≤ {r} + {t}"}[self.op]

    def render(self):
        """``what: paper P, ours O; rule R → holds|fails``."""
        const = self.ref_name[:1].isdigit()  # a fixed bound ("0", "5%"): the rule states it
        ours = f"{self.name} {_fmt(self.ours)}"
        vals = ours if const else f"{self.ref_name} {_fmt(self.ref)}, {ours}"
        if self.paper is not None and self.ref_name != "paper":
            vals = f"paper {_fmt(self.paper)}; " + vals
        return f"{self.what}: {vals}; rule {self.rule()} → {'holds' if self.ok else 'fails'}"


# ----------------------------------------------------------------------------- reading the committed CSVs

def _rows(folder, name):
    path = Path(folder) / name
    if not path.is_file():
        return []
    with path.open(newline="", encoding="utf-8") as f:
        return list(csv.DictReader(f))


def _num(x):
    try:
        return float(x)
    except (TypeError, ValueError):
        return float("nan")


def _pick(rows, **kw):
    return next((r for r in rows if all(r.get(k) == v for k, v in kw.items())), None)


def _val(row, key):
    """``row[key]`` as a float (NaN for a blank: e.g. a method that failed to initialise); None without a row."""
    return _num(row[key]) if row else None


# ----------------------------------------------------------------------------- Table 1 (tab:compact_prelim)

def _compact(folder):
    return _rows(folder, "compact_prelim.csv")


def _c(rows, mesh, method, key):
    return _val(_pick(rows, mesh=mesh, method=method, mode="whole"), key)


def _hand_all_fold(folder, claim):
    from neuraluv_paper.bench import paper_values as PV

    rows = _compact(folder)
    return [Check(f"Hand / {m.upper() if m != 'slim-1k' else 'SLIM-1k'} flip %", _c(rows, "hand", m, "flip_percent"), ">", 0.0,
                  "0", paper=PV.COMPACT_PRELIM[("hand", m)]["flip_percent"]) for m in ("lscm", "arap", "slim-1k", "bff")]


def _bob_bff_higher(folder, claim):
    rows = _compact(folder)
    ours = {k: _c(rows, "bob", "neural", k) for k in ("esd", "area")}
    return [Check(f"Bob / {lab}", _c(rows, "bob", "bff", k), ">", ours[k], "ours (neural)", tol=0.01, name="BFF")
            for k, lab in (("esd", "E_SD"), ("area", "area distortion"))]


def _bob_both_zero(folder, claim):
    rows = _compact(folder)
    return [Check(f"Bob / {lab} flip %", _c(rows, "bob", m, "flip_percent"), "≤", 0.0, "0", absolute=True, paper=0.0)
            for m, lab in (("bff", "BFF"), ("neural", "ours"))]


def _camel_slim_better(folder, claim):
    rows = _compact(folder)
    return [Check("Camel / SLIM-1k flip %", _c(rows, "camel", "slim-1k", "flip_percent"), "≤", 0.0, "0", absolute=True,
                  paper=0.0),
            Check("Camel / E_SD", _c(rows, "camel", "slim-1k", "esd"), "<", _c(rows, "camel", "neural", "esd"),
                  "ours (neural)", paper=4.09, name="SLIM-1k")]


def _camel_still_fold(folder, claim):
    from neuraluv_paper.bench import paper_values as PV

    rows = _compact(folder)
    out = []
    for m, lab in (("lscm", "LSCM"), ("arap", "ARAP")):
        p = PV.COMPACT_PRELIM[("camel", m)]["flip_percent"]
        out.append(Check(f"Camel / {lab} flip %", _c(rows, "camel", m, "flip_percent"), ">", 0.0, "0", paper=p))
    return out


def _slower(folder, claim):
    rows = _compact(folder)
    out = []
    for mesh in ("hand", "bob", "camel"):
        others = [_c(rows, mesh, m, "time") for m in ("lscm", "arap", "bff")]
        fastest_other = max(t for t in others if t is not None and not math.isnan(t))
        out.append(Check(f"{mesh.title()} time (s)", _c(rows, mesh, "neural", "time"), ">", fastest_other,
                         "slowest of LSCM/ARAP/BFF", name="ours (neural)"))
    return out


def _optcuts_resolves(folder, claim):
    rows = _compact(folder)
    return [Check(f"{mesh.title()} / OptCuts flip %", _c(rows, mesh, "optcuts", "flip_percent"), "≤", 0.0, "0",
                  absolute=True, paper=0.0) for mesh in ("hand", "camel")]


def _bff_binary(folder, claim):
    rows = _compact(folder)
    out = []
    for mesh in ("hand", "bob", "camel"):
        out.append(Check(f"{mesh.title()} / BFF v1.6 binary E_SD", _c(rows, mesh, "bff-cli", "esd"), "≈",
                         _c(rows, mesh, "bff", "esd"), "our Python BFF", tol=0.01, name="binary"))
        out.append(Check(f"{mesh.title()} / BFF v1.6 binary flip %", _c(rows, mesh, "bff-cli", "flip_percent"), "≈",
                         _c(rows, mesh, "bff", "flip_percent"), "our Python BFF", tol=0.01, absolute=True,
                         name="binary"))
    return out


# ----------------------------------------------------------------------------- Table 2 (tab:slim_failure_modes)

def _failure_mode(folder, claim):
    """``"<Mesh> / <Method>: paper reports 13.56% flips"`` (flip % within ±20%) or ``"E_SD=4.09"`` (within ±5%);
    a reported failure ("init fail") is a category, not a number: no check (qualitative)."""
    from neuraluv_paper.bench.common import LABELS, MESH_LABELS

    labels = {**LABELS, "bff-cli": "BFF v1.6 binary", "optcuts": "OptCuts (re-cut)"}
    head, paper_cell = claim.split(": paper reports ", 1)
    for r in _rows(folder, "slim_failure_modes.csv"):
        if f"{MESH_LABELS.get(r['mesh'], r['mesh'])} / {labels.get(r['method'], r['method'])}" == head:
            break
    else:
        return []
    what = head
    if paper_cell.endswith("% flips"):
        return [Check(f"{what} flip %", _num(r["flip_percent"]), "≈", _num(paper_cell.split("%")[0]), tol=0.20)]
    if paper_cell.startswith("E_SD="):
        return [Check(f"{what} E_SD", _num(r["esd"]), "≈", _num(paper_cell[5:]), tol=0.05)]
    return []


# ----------------------------------------------------------------------------- Table 3 (tab:ablation_prelim)

def _ablation(folder):
    return {r["variant"]: r for r in _rows(folder, "ablation_prelim.csv")}


def _k0_hurts(folder, claim):
    S = _ablation(folder)
    if not {"full", "k=0"} <= S.keys():
        return []
    f, k = S["full"], S["k=0"]
    noise = _num(f["esd_sd"]) + _num(k["esd_sd"])
    return [Check("E_SD (seed spreads added as the margin)", _num(k["esd"]), ">", _num(f["esd"]), "full",
                  tol=noise if noise == noise else 0.0, absolute=True, paper=_num(k["paper_esd"]), name="k=0"),
            Check("min det J", _num(k["min_det"]), "<", _num(f["min_det"]), "full", paper=_num(k["paper_min_det"]),
                  name="k=0"),
            Check("k=0 flip %", _num(k["flip_percent"]), "≤", 0.0, "0", absolute=True, paper=0.0)]


def _bandwidth_flat(folder, claim):
    S = _ablation(folder)
    e = [_num(S[v]["esd"]) for v in ("omega0=5", "omega0=10", "full", "omega0=20", "omega0=30") if v in S]
    if len(e) < 3:
        return []
    return [Check("E_SD spread over ω0 (max/min − 1, %)", 100 * (max(e) / min(e) - 1), "≤", 5.0, "5", absolute=True,
                  paper=100 * (7.10 / 7.08 - 1))]


def _init_invalid(folder, claim):
    v = "spectral init" if claim.startswith("Spectral") else "random init"
    r = _ablation(folder).get(v)
    if r is None:
        return []
    return [Check(f"{v}: valid charts", _num(r["valid"]), "≤", 0.0, "0", absolute=True, paper=0.0),
            Check(f"{v}: flip %", _num(r["flip_percent"]), ">", 0.0, "0", paper=_num(r["paper_flip_percent"]))]


# ----------------------------------------------------------------------------- Table 4 (tab:ntk_compact_controls)

def _ntk(folder):
    return _rows(folder, "ntk_compact_controls.csv")


def _s(rows, state, k, omega0, col):
    return _val(_pick(rows, state=state, k=str(k), omega0=f"{float(omega0)}"), col)


def _ntk_raise(r):
    def rule(folder, claim):
        rows = _ntk(folder)
        col = f"S{r}"
        d = _s(rows, "init", 16, 15, col) - _s(rows, "init", 0, 15, col)
        dp = _s(rows, "init", 16, 15, col + "_paper") - _s(rows, "init", 0, 15, col + "_paper")
        return [Check(f"S({r}) at init, k=16 − k=0", d, ">", 0.0, "0", tol=0.02, absolute=True, paper=dp)]
    return rule


def _ntk_gap_shrinks(folder, claim):
    rows = _ntk(folder)
    g0 = _s(rows, "init", 16, 15, "S16") - _s(rows, "init", 0, 15, "S16")
    g1 = _s(rows, "final", 16, 15, "S16") - _s(rows, "final", 0, 15, "S16")
    p0 = _s(rows, "init", 16, 15, "S16_paper") - _s(rows, "init", 0, 15, "S16_paper")
    p1 = _s(rows, "final", 16, 15, "S16_paper") - _s(rows, "final", 0, 15, "S16_paper")
    return [Check(f"S(16) gap k=16 − k=0 (paper {_fmt(p0)} → {_fmt(p1)})", g1, "<", g0, "at init", tol=0.1,
                  name="after optimisation")]


def _ntk_omega30(folder, claim):
    rows = _ntk(folder)
    a, b = _s(rows, "init", 16, 30, "S16"), _s(rows, "init", 16, 15, "S16")
    return [Check("S(16) at init (k=16)", a, "<", b, "ω0=15", tol=0.02, absolute=True,
                  paper=_s(rows, "init", 16, 30, "S16_paper"), name="ω0=30")]


# ----------------------------------------------------------------------------- Table 5 (tab:thingi_scale)

def _thingi(folder):
    return _rows(folder, "thingi_scale.csv")


def _share(r):
    return 100 * _num(r["valid"]) / _num(r["tried"]) if r else float("nan")


def _small_valid(folder, claim):
    r = _pick(_thingi(folder), method="neural", subset="first-N")
    return [Check("xatlas first-N valid %", _share(r), "≥", 97.6, tol=0.02)]


def _strat_valid(folder, claim):
    r = _pick(_thingi(folder), method="neural", subset="all")
    return [Check("stratified valid %", _share(r), "≥", 89.4, tol=0.02)]


def _valid_drops(folder, claim):
    rows = _thingi(folder)
    return [Check("valid %", _share(_pick(rows, method="neural", subset="all")), "<",
                  _share(_pick(rows, method="neural", subset="first-N")), "first-N", paper=89.4, name="stratified")]


def _esd_grows(folder, claim):
    rows = _thingi(folder)
    small = _val(_pick(rows, method="neural", subset="first-N"), "median_esd")
    large = [r for r in rows if r["method"] == "neural" and r["subset"] not in ("first-N", "all")]
    big = _val(large[-1], "median_esd") if large else float("nan")
    return [Check("median E_SD", big, ">", small, "xatlas first-N", tol=0.05, paper=60.56,
                  name=large[-1]["label"] if large else "largest stratum")]


def _k16_valid(folder, claim):
    rows = _thingi(folder)
    return [Check("stratified valid charts", _val(_pick(rows, method="neural", subset="all"), "valid"), "≥",
                  _val(_pick(rows, method="neural-k0", subset="all"), "valid"), "k=0", paper=42, name="k=16")]


def _k16_tradeoff(folder, claim):
    rows = _thingi(folder)
    runs = _rows(folder, "thingi_scale_runs.csv")

    def med_det(method):
        d = sorted(_num(r["min_det"]) for r in runs if r["method"] == method and r["stratum"] != "first-N"
                   and r["valid"] == "True")
        return d[len(d) // 2] if d else float("nan")

    return [Check("stratified median E_SD", _val(_pick(rows, method="neural", subset="all"), "median_esd"), ">",
                  _val(_pick(rows, method="neural-k0", subset="all"), "median_esd"), "k=0", tol=0.01, paper=99.68,
                  name="k=16"),
            Check("stratified median min det J", med_det("neural"), "<", med_det("neural-k0"), "k=0", tol=0.01,
                  paper=0.047, name="k=16")]


# ----------------------------------------------------------------------------- Table 6 (tab:runtime_pareto)

def _pareto(folder, group):
    rows = [r for r in _rows(folder, "runtime_pareto.csv") if r["set"] == group]
    return sorted(rows, key=lambda r: _num(r["iterations"]))


def _zero_flip(group):
    def rule(folder, claim):
        return [Check(f"{group} / {r['iterations']} it. mean flip %", _num(r["mean_flip"]), "≤", 0.0, "0", absolute=True,
                      paper=0.0) for r in _pareto(folder, group)]
    return rule


def _saturates(folder, claim):
    rows = _pareto(folder, "compact")
    e = [_num(r["median_esd"]) for r in rows]
    if len(e) < 2:
        return []
    return [Check(f"compact: median E_SD gain {rows[-2]['iterations']} → {rows[-1]['iterations']} it. (%)",
                  100 * (e[-2] - e[-1]) / e[-2], "≤", 5.0, "5", absolute=True, paper=100 * (4.42 - 4.39) / 4.42)]


def _keeps_improving(folder, claim):
    rows = _pareto(folder, "xatlas")
    e = [_num(r["median_esd"]) for r in rows]
    if len(e) < 2:
        return []
    return [Check("xatlas: median E_SD", e[-1], "<", e[0], f"{rows[0]['iterations']} it.", tol=0.05, paper=29.09,
                  name=f"{rows[-1]['iterations']} it.")]


# ----------------------------------------------------------------------------- Table 7 (tab:amara_coverage_validity)

def _amara_full(folder, claim):
    rows = [r for r in _rows(folder, "amara_runs.csv") if r["method"] == "ours"]
    faces = sum(_num(r["faces"]) for r in rows)
    cov = 100 * sum(_num(r["coverage"]) * _num(r["faces"]) for r in rows) / faces if faces else float("nan")
    return [Check("coverage % of repaired faces", cov, "≥", 100.0, paper=100.0),
            Check("flipped faces", sum(_num(r["flips"]) for r in rows), "≤", 0.0, "0", absolute=True, paper=0.0)]


def _amara_charts(folder, claim):
    rows = [r for r in _rows(folder, "amara_runs.csv") if r["method"] == "ours"]
    n, ok = sum(_num(r["neural_charts"]) for r in rows), sum(_num(r["neural_zero_flip"]) for r in rows)
    return [Check("zero-flip share of accepted neural charts (%)", 100 * ok / n if n else float("nan"), "≥", 100.0,
                  paper=100.0)]


#: (report file name, start of the claim) -> rule(folder, claim) -> list of Check. The folder is the claim's report's.
RULES = {
    ("compact_prelim.md", "Hand: LSCM, ARAP, SLIM-1k and BFF all fold"): _hand_all_fold,
    ("compact_prelim.md", "Bob: BFF and ours both solve it"): _bob_both_zero,
    ("compact_prelim.md", "Bob: BFF has higher E_SD"): _bob_bff_higher,
    ("compact_prelim.md", "Camel: SLIM-1k is zero-flip"): _camel_slim_better,
    ("compact_prelim.md", "Camel: LSCM and ARAP still fold"): _camel_still_fold,
    ("compact_prelim.md", "Our PyTorch solver is slower"): _slower,
    ("compact_prelim.md", "OptCuts resolves Hand and Camel"): _optcuts_resolves,
    ("compact_prelim.md", "(ours, not the paper's) the BFF v1.6 binary"): _bff_binary,
    ("slim_failure_modes.md", ""): _failure_mode,
    ("ablation_prelim.md", "Removing LBO features"): _k0_hurts,
    ("ablation_prelim.md", "The bandwidth rows are nearly flat"): _bandwidth_flat,
    ("ablation_prelim.md", "Spectral init"): _init_invalid,
    ("ablation_prelim.md", "Random init"): _init_invalid,
    ("ntk_compact_controls.md", "Spectral inputs raise S(16)"): _ntk_raise(16),
    ("ntk_compact_controls.md", "Spectral inputs raise S(4)"): _ntk_raise(4),
    ("ntk_compact_controls.md", "The k=16 vs k=0 S(16) gap shrinks"): _ntk_gap_shrinks,
    ("ntk_compact_controls.md", "omega0=30 weakens"): _ntk_omega30,
    ("thingi_scale.md", "The small-chart sweep is almost all valid"): _small_valid,
    ("thingi_scale.md", "The stratified set is mostly valid"): _strat_valid,
    ("thingi_scale.md", "The valid fraction drops on larger charts"): _valid_drops,
    ("thingi_scale.md", "Median E_SD grows with chart size"): _esd_grows,
    ("thingi_scale.md", "On the stratified charts k=16 solves"): _k16_valid,
    ("thingi_scale.md", "…but with higher median E_SD"): _k16_tradeoff,
    ("runtime_pareto.md", "compact: every budget stays zero-flip"): _zero_flip("compact"),
    ("runtime_pareto.md", "xatlas: every budget stays zero-flip"): _zero_flip("xatlas"),
    ("runtime_pareto.md", "compact: median E_SD saturates"): _saturates,
    ("runtime_pareto.md", "larger charts keep improving"): _keeps_improving,
    ("amara_coverage_validity.md", "the full atlas path covers every repaired face"): _amara_full,
    ("amara_coverage_validity.md", "every accepted neural chart is zero-flip"): _amara_charts,
}


def checks_for(source, claim, root):
    """The numeric checks of one claim (an empty list: no rule, the claim is qualitative).

    Parameters
    ----------
    source : str
        The claim's report relative to ``results/`` (``"compact/cuda/compact_prelim.md"``).
    claim : str
    root : path
        The ``results/`` folder.

    Returns
    -------
    list of Check
        Empty also when the numbers a rule needs are not in the committed CSV.
    """
    if source is None:
        return []
    path = Path(root) / source
    for (report, start), rule in RULES.items():
        if path.name == report and claim.startswith(start):
            try:
                checks = rule(path.parent, claim)
            except (KeyError, TypeError, ValueError, ZeroDivisionError, StopIteration):  # numbers missing
                return []
            # a number the committed CSV does not have (no such row: e.g. a CUDA run of ours only) is no check
            return [c for c in checks if c.ours is not None and c.ref is not None and not math.isnan(float(c.ref))]
    return []
