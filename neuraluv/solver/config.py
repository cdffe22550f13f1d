"""Solver settings: the paper's numbers in one place, importable without torch.

:class:`SolverConfig` holds every setting of the chart solver with the paper's
values as defaults (Sec. 3–4: SIREN ω₀=15, 5 layers, width 256, k=16, ε_J=1e-4,
ε=1e-3, α 10→0.1, 200 warm-up and 5,000 Adam iterations, cosine LR 5e-4→1e-6);
:data:`PRESETS` names the configurations the package ships.
"""
from __future__ import annotations

from dataclasses import asdict, dataclass, replace

__all__ = ["SolverConfig", "PRESETS", "PRESET_HELP", "get_config"]


@dataclass(frozen=True)
class SolverConfig:
    """All solver settings; the defaults are the paper's (Sec. 3–4).

    Attributes
    ----------
    k : spectral rank (number of LBO eigenfunctions in the input).
    omega0, width, n_layers : SIREN frequency, hidden width, linear layers incl. head.
    init : ``"tutte"`` (valid start), ``"spectral"`` or ``"random"`` (ablations).
    residual : residual head on the Tutte map (True) or absolute output (False).
    eps_J : switch point of the C² inverse-determinant extension.
    eps : barrier margin; ``alpha_start → alpha_end`` its annealed weight.
    lr, lr_min : cosine learning-rate range.
    betas : Adam's moment decay rates. The paper does not state them; with
        PyTorch's default beta2 = 0.999 one gradient spike from a nearly
        collapsed triangle dominates the second-moment estimate for ~1,000
        steps and the solve crawls. beta2 = 0.95 was the best of 0.999, 0.99
        and 0.95 on all three compact charts (docs/RESULTS.md).
    warmup_iters : iterations fitting the network to the initial map.
    iterations : energy-optimisation iterations.
    reject : determinant-aware step rejection on/off.
    det_drop : a step is also rejected when it pushes the smallest determinant
        below ``min(eps, det_drop * previous min det)`` (0 disables this guard).
    max_backtracks, backtrack : halvings of the step allowed per iteration.
    step_recover : after an accepted step the step scale grows by this factor
        (capped at 1); 1.0 keeps every reduction for the rest of the solve. Not
        in the paper (which says only "reduce the learning rate and retry"):
        1.1 replaced 2.0, whose jump back to the full step after every refusal
        made 43% of Camel's trials fail; with 1.1, 11% fail and the `paper`
        results are unchanged within seed noise (docs/RESULTS.md).
    early_stop, patience, tol, early_after : stop when the best E_SD improved by
        less than ``tol`` (relative) over the last ``patience`` iterations,
        checked from ``early_after`` × the budget on (Adam's trajectories often
        plateau early, then improve: 0.5 by default). ``fast`` (L-BFGS, whose
        best E_SD falls steadily) checks from the first ``patience`` = 50 steps
        on with ``tol`` = 5e-4 — the slope of its former 200 steps / 2e-3, seen
        over a quarter of the window, so a chart that has converged stops after
        50 steps instead of at least 200 (issue 28): on the atlases of cow, spot
        and three generated assets 27% fewer solver rounds in all (9,307 → 6,760)
        at the same face-weighted E_SD within 0.001 (one asset 4.051 → 4.006);
        Hand / Bob / Camel's E_SD equal within 0.003. A chart whose best E_SD is
        within ``4 · tol`` of an isometry's (4, the least of any map) stops at
        once: no window of steps can improve it by ``tol`` any more, so the
        plateau test would stop it at its first check.
    ftol, ftol_steps : with ``early_stop``, a chart whose best E_SD improved by
        less than ``ftol`` (relative) over its last ``ftol_steps`` accepted steps
        has converged to rounding and stops then, without waiting ``patience``
        steps (the relative-reduction test of L-BFGS-B, ``factr · eps`` ≈ 2e-9,
        held over a few steps because one heavily backtracked step can gain that
        little on a chart that is still moving). ``ftol = 0`` turns it off.
    retries : extra attempts (next seed, halved learning rate) if a solve ends invalid.
    loss_rise : not in the paper's text. A step is also rejected when it raises the
        loss by more than this fraction (0 disables the guard). Algorithm 1
        already rejects on "quality thresholds"; without this guard Adam's
        accepted overshoots (E_SD excursions from ~5 to 10–1,000 when a
        triangle nearly collapses) cost hundreds of iterations each.
    optimizer : ``"adam"`` (the paper's) or ``"lbfgs"`` (limited-memory BFGS whose
        line-search trials pass the same validity checks; ``lr`` is then the
        length of the first steepest-descent step, ``lr_min`` unused).
    history : L-BFGS memory (curvature pairs kept).
    armijo : L-BFGS sufficient-decrease constant ``c₁`` (a trial must lower the
        loss by ``c₁ t ∇L·d``; replaces ``loss_rise``).
    param : what the optimiser moves. ``"siren"`` (the paper's): the weights of the
        chart network, ``u = φ_θ(x)``. ``"vertex"``: free per-vertex UVs,
        ``u = u_start + θ`` with ``θ (n,2)`` starting at zero — the same start,
        objective, barrier, C² extension, checked steps, optimiser, retries and
        fallback, only the parameters differ (the control of "what the network
        adds", :mod:`neuraluv.solver.vertex`, notebook 03d). The network
        settings (``k``, ``omega0``, ``width``, ``n_layers``) are then unused; ``lr`` is
        Adam's step per UV coordinate (or L-BFGS's first step length).
    start_relax, relax_below : not in the paper (``literal`` preset: off). When the
        Tutte start's smallest det J is below ``relax_below`` (default ``ε_J``,
        where the C² extension replaces the true energy), it is un-crushed by
        flip-free SLIM iterations (:func:`neuraluv.relax.slim_relax_until`),
        one at a time and stopping as soon as every det J reaches the barrier
        margin ``eps``, at most ``start_relax`` of them; then the residual
        network is attached. Uniform Tutte maps crush long protrusions
        exponentially (Hand: min det J 2e-10), and from there every Adam step
        of a network that is smooth in 3D flips or further collapses a crushed
        triangle, so the literal recipe makes no progress; see docs/RESULTS.md.
    start_slim : not in the paper (every preset: 0; the atlas's routing sets it,
        :data:`neuraluv.atlas.routing.START_SLIM`). SLIM iterations at most
        (:func:`neuraluv.relax.slim_relax_while`, libigl) that then move the start towards
        the chart's flattening for as long as it stays injective — no flipped face and an
        outer boundary that does not cross itself — before the residual network is
        attached. The solve then starts near the optimum instead of from the circle's
        distortion: strips of 10–31 faces (chair_model's charts) start at E_SD 146–453 on
        their Tutte circle and took the ``fast`` solver 382–655 steps, most of them travelling.
        On a large chart whose flattening overlaps itself (Camel) the boundary crosses after
        one or two iterations, and the start is nearly the Tutte map; on a chart with
        protrusions (the procedural glove) the solve can stop earlier and higher (E_SD
        4.053 against 4.002 from the Tutte map).
    """

    k: int = 16
    omega0: float = 15.0
    width: int = 256
    n_layers: int = 5
    init: str = "tutte"
    residual: bool = True
    eps_J: float = 1e-4
    eps: float = 1e-3
    alpha_start: float = 10.0
    alpha_end: float = 0.1
    lr: float = 5e-4
    betas: tuple = (0.9, 0.95)
    lr_min: float = 1e-6
    warmup_iters: int = 200
    warmup_lr: float = 1e-4
    iterations: int = 5000
    reject: bool = True
    max_backtracks: int = 12
    det_drop: float = 0.5
    loss_rise: float = 0.005
    step_recover: float = 1.1
    backtrack: float = 0.5
    early_stop: bool = False
    patience: int = 100
    tol: float = 1e-3
    early_after: float = 0.5
    ftol: float = 1e-9
    ftol_steps: int = 5
    retries: int = 2
    start_relax: int = 100
    relax_below: float = 1e-4
    start_slim: int = 0
    optimizer: str = "adam"
    history: int = 30
    armijo: float = 1e-4
    param: str = "siren"

    def as_dict(self):
        return asdict(self)


#: Named configurations.
#:
#: ``paper``: the published network and budget (5x256 SIREN, ω₀ = 15, 5,000
#: Adam iterations) with the stated, measured deviations of the defaults
#: above: Adam beta2 = 0.95, the det-drop and loss-rise rejection guards, and
#: a crushed Tutte start un-crushed by SLIM (docs/RESULTS.md). ``literal``:
#: the paper's text only (PyTorch Adam defaults, rejection on flips alone,
#: plain Tutte start), kept to show what the deviations buy. ``fast``: the
#: same recipe (SIREN on LBO features, residual on the Tutte start, C²
#: objective + barrier, validity-checked steps, retries, marked fallbacks)
#: with a smaller, higher-bandwidth network (4x64, ω₀ = 45) optimised by
#: L-BFGS whose line-search trials pass the same checks; chosen from the
#: Pareto study in results/speed/pareto.md. ``test``: a tiny network for
#: unit tests and doctests only.
PRESETS = {
    "paper": SolverConfig(),
    "literal": SolverConfig(betas=(0.9, 0.999), det_drop=0.0, loss_rise=0.0, start_relax=0),
    "fast": SolverConfig(width=64, n_layers=4, omega0=60.0, optimizer="lbfgs", lr=1e-2, history=30,
                         iterations=2000, early_stop=True, patience=50, tol=5e-4, early_after=0.0),
    "test": SolverConfig(k=8, width=32, n_layers=3, iterations=60, warmup_iters=20, patience=20),
}


#: One line per preset, for ``--help`` texts and reports.
PRESET_HELP = {
    "paper": "the published network and budget (5x256 SIREN, 5,000 Adam iterations) with the stated deviations",
    "literal": "the paper's text only (Adam defaults, rejection on flips alone, plain Tutte start)",
    "fast": (f"the default: the paper's recipe with a {PRESETS['fast'].n_layers}x{PRESETS['fast'].width} SIREN "
             f"(omega0 {PRESETS['fast'].omega0:g}) and L-BFGS, <= {PRESETS['fast'].iterations:,} validated steps"),
    "test": "a tiny network for unit tests and doctests (not for real use)",
}


def get_config(preset="fast", **overrides):
    """A preset's :class:`SolverConfig`, with field overrides.

    Examples
    --------
    >>> get_config("paper").iterations, get_config("test", iterations=5).iterations
    (5000, 5)
    """
    if isinstance(preset, SolverConfig):
        cfg = preset
    else:
        if preset not in PRESETS:
            raise ValueError(f"unknown preset {preset!r}; choose one of {sorted(PRESETS)}")
        cfg = PRESETS[preset]
    return replace(cfg, **overrides) if overrides else cfg
