"""The notebooks' one runtime switch: quick (CI) runs or paper-scale runs.

Every notebook in ``notebooks/`` runs in about a minute on a 2-core CPU by
default: the real compact charts (Camel, Hand, Bob; :func:`load_chart`) wherever
the lesson is a real failure, the real ``"fast"`` preset or short budgets, fixed
seeds; procedural charts only where a construction is the point, never as
stand-ins: a chapter that needs a real mesh which is not cached stops at that
cell with one line naming ``make data`` (:class:`~neuraluv.datasets.DataMissing`,
shown without a traceback once :func:`setup` ran). Setting the environment variable
``NEURALUV_PAPER_SCALE=1`` before starting Jupyter (or ``make book``) switches
every notebook to the paper's settings (the ``"paper"`` preset, the compact real
charts). Notebooks choose between the two with :func:`budget`, and print the
committed reference points beside their own numbers with :func:`reference`
(e.g. SLIM-1k on the same chart; :func:`neuraluv_paper.claims.reference`).

On a hosted notebook service (Colab, Binder; :func:`hosted`) each chapter's first code cell
(tagged ``hosted-setup``, source :func:`hosted_setup_source`) installs the package when it is
missing and fetches the meshes with :func:`fetch_data`; in a checkout it does nothing.

The module also keeps the notebooks quiet (:func:`setup` routes VTK to an
off-screen EGL window when there is no display and imports tqdm without its
widget warning). The claims checklist each chapter ends with is the harness's
(:mod:`neuraluv_paper.claims`).
"""
from __future__ import annotations

import ctypes.util
import os
import random
import warnings

import numpy as np

from neuraluv import datasets

__all__ = ["ENV_VAR", "paper_scale", "budget", "setup", "mode", "load_chart", "quiet_environment", "one_line_errors",
           "HOSTED_ENV", "hosted", "fetch_data", "hosted_setup_source"]

#: Name of the environment variable that selects paper-scale runs.
ENV_VAR = "NEURALUV_PAPER_SCALE"

_TRUE = {"1", "true", "yes", "on"}


def paper_scale(environ=None) -> bool:
    """True when ``NEURALUV_PAPER_SCALE`` is set to 1/true/yes/on.

    Parameters
    ----------
    environ : mapping, optional
        Where to read the variable (default ``os.environ``).

    Examples
    --------
    >>> paper_scale({"NEURALUV_PAPER_SCALE": "1"}), paper_scale({})
    (True, False)
    """
    env = os.environ if environ is None else environ
    return env.get(ENV_VAR, "").strip().lower() in _TRUE


def budget(quick, paper, *, scale=None):
    """Pick the quick or the paper-scale value of a setting.

    Parameters
    ----------
    quick : any
        Value for the default quick run (CI, about a minute per notebook).
    paper : any
        Value for ``NEURALUV_PAPER_SCALE=1``.
    scale : bool, optional
        Force a mode (default: :func:`paper_scale`).

    Examples
    --------
    >>> budget(200, 5000, scale=False), budget(200, 5000, scale=True)
    (200, 5000)
    """
    return paper if (paper_scale() if scale is None else scale) else quick


def mode() -> str:
    """A one-line description of the active mode, printed by :func:`setup`."""
    if paper_scale():
        return f"paper-scale run ({ENV_VAR}=1): expect minutes to hours on a CPU"
    return f"quick run (set {ENV_VAR}=1 for paper-scale settings)"


def setup(seed=0, threads="auto"):
    """Seed every random generator and set torch's CPU threads; returns the mode line.

    Parameters
    ----------
    seed : int
    threads : int, "auto" or None
        ``torch.set_num_threads`` value. ``"auto"``: one thread for quick runs
        (the tiny networks run fastest single-threaded, especially on a shared
        machine), torch's default at paper scale. None leaves it alone.

    Examples
    --------
    >>> setup(0, threads=None).startswith(("quick", "paper"))
    True
    """
    import torch

    quiet_environment()
    one_line_errors()
    random.seed(seed)
    np.random.seed(seed)
    torch.manual_seed(seed)
    if threads == "auto":
        threads = None if paper_scale() else 1
    if threads:
        torch.set_num_threads(int(threads))
    return mode()


def quiet_environment(environ=None):
    """Silence the two stray stderr lines a notebook kernel would otherwise print.

    * VTK: without a display, pyvista's default X window prints "bad X server
      connection" on the first render. When no ``DISPLAY`` is set and libEGL is
      present, VTK is pointed at its EGL window (``VTK_DEFAULT_OPENGL_WINDOW``),
      which renders off screen without X; a user's own setting is kept.
    * tqdm: ``tqdm.auto`` warns "IProgress not found" once, on import, in a
      kernel without ipywidgets (pyvista imports it). It is imported here with
      that warning suppressed (it then falls back to the text bar).

    Parameters
    ----------
    environ : mutable mapping, optional
        Where to set the variables (default ``os.environ``).

    Returns
    -------
    dict
        The variables it set (empty when it changed nothing).

    Examples
    --------
    >>> quiet_environment({"DISPLAY": ":0", "PYVISTA_OFF_SCREEN": "true"})
    {}
    """
    env = os.environ if environ is None else environ
    changed = {}
    if "PYVISTA_OFF_SCREEN" not in env:
        changed["PYVISTA_OFF_SCREEN"] = "true"
    if not env.get("DISPLAY") and "VTK_DEFAULT_OPENGL_WINDOW" not in env and ctypes.util.find_library("EGL"):
        changed["VTK_DEFAULT_OPENGL_WINDOW"] = "vtkEGLRenderWindow"
    env.update(changed)
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", message=".*IProgress not found.*")
        try:
            import tqdm.auto  # noqa: F401  (cached: later imports do not warn again)
        except ImportError:
            pass
    return changed


def one_line_errors(shell=None):
    """Show a :class:`~neuraluv.datasets.DataMissing` in a notebook as its one line, without a traceback.

    The cell still fails, so "Run All" stops there; only the display changes.

    Parameters
    ----------
    shell : IPython shell, optional
        Default: the running one (nothing happens outside IPython).

    Returns
    -------
    bool
        True when the handler was installed.

    Examples
    --------
    >>> one_line_errors()  # a doctest is not an IPython kernel
    False
    """
    if shell is None:
        try:
            from IPython import get_ipython
        except ImportError:
            return False
        shell = get_ipython()
    if shell is None:
        return False

    def _one_line(shell, etype, value, _tb, tb_offset=None):
        # shown as the cell's error (ename, evalue, a one-line traceback); the kernel still replies "error"
        shell._showtraceback(etype, value, [f"{etype.__name__}: {value}"])

    shell.set_custom_exc((datasets.DataMissing,), _one_line)
    return True


def load_chart(quick="glove", paper="camel", **quick_kwargs):
    """Load the notebook's chart: ``quick`` by default, ``paper`` at paper scale.

    A procedural name (:data:`neuraluv.datasets.PROCEDURAL`) is built in code: a
    chapter that means to use one says so. A real mesh that is not cached is an
    error, never a silent stand-in: :class:`~neuraluv.datasets.DataMissing`
    with one line naming ``make data`` and the folder searched.

    Parameters
    ----------
    quick, paper : str
        Names accepted by :func:`neuraluv.datasets.load`.
    **quick_kwargs
        Size options for a procedural ``quick`` chart (e.g. ``n_rings=8``),
        passed to :func:`neuraluv.datasets.procedural`.

    Returns
    -------
    name : str
        The chart loaded.
    V : (n,3) float array
    F : (m,3) int array

    Raises
    ------
    neuraluv.datasets.DataMissing
        The real mesh is not in :func:`neuraluv.datasets.data_dir`.

    Examples
    --------
    >>> name, V, F = load_chart("disk", "camel", n_rings=2)
    >>> name, V.shape, F.shape
    ('disk', (19, 3), (24, 3))
    """
    name = paper if paper_scale() else quick
    if name in datasets.PROCEDURAL:
        return (name, *datasets.procedural(name, **(quick_kwargs if name == quick else {})))
    try:
        return (name, *datasets.load(name))
    except datasets.DataMissing:
        raise datasets.DataMissing(f"this chapter needs the real mesh {name!r}, which is not in "
                                   f"{datasets.data_dir()}: {datasets.FETCH_HINT}, then rerun it") from None


#: Set this environment variable (to 1) to make a kernel count as hosted (:func:`hosted`) anywhere.
HOSTED_ENV = "NEURALUV_HOSTED"
#: Environment variables a hosted service sets: Colab's release tag, mybinder.org's launch host.
_HOSTED_MARKERS = (HOSTED_ENV, "COLAB_RELEASE_TAG", "BINDER_LAUNCH_HOST")


def hosted(environ=None, modules=None) -> bool:
    """True in a hosted notebook service: Colab (``google.colab`` imported), Binder, or ``NEURALUV_HOSTED=1``.

    The same test as the chapters' set-up cell (:func:`hosted_setup_source`).

    Parameters
    ----------
    environ : mapping, optional
        Default ``os.environ``.
    modules : mapping, optional
        Default ``sys.modules``.

    Examples
    --------
    >>> hosted({}, {}), hosted({"NEURALUV_HOSTED": "1"}, {}), hosted({}, {"google.colab": None})
    (False, True, True)
    """
    import sys

    env = os.environ if environ is None else environ
    mods = sys.modules if modules is None else modules
    return "google.colab" in mods or any(env.get(k, "").strip().lower() not in ("", "0", "false", "no")
                                         for k in _HOSTED_MARKERS)


def fetch_data(source=None, *, download=True, authored=True, echo=print):
    """Fetch every registry mesh (and the authored assets) into :func:`neuraluv.datasets.data_dir`.

    What the set-up cell runs on a hosted service after installing the package (the same as ``make data``
    without a mirror: about 25 MB of meshes, hash-checked).

    Parameters
    ----------
    source : path-like, optional
        A local mirror folder instead of the upstream URLs.
    download : bool
    authored : bool
        Also the authored assets of notebook 09 (:data:`neuraluv.datasets.AUTHORED`).
    echo : callable
        Receives the one-line summary.

    Returns
    -------
    dict
        ``{name: path or error message}``.
    """
    got = dict(datasets.fetch_all(source, download=download))
    if authored:
        got.update(datasets.fetch_authored(source, download=download))
    bad = sorted(k for k, v in got.items() if isinstance(v, str))
    echo(f"neuraluv data: {len(got) - len(bad)} of {len(got)} files in {datasets.data_dir()}"
         + (f"; missing: {', '.join(bad)}" if bad else ""))
    return got


def hosted_setup_source(repo_url):
    """The source of every chapter's first code cell (tagged ``hosted-setup``): set-up on a hosted service.

    On Colab, Binder or with ``NEURALUV_HOSTED=1`` (:func:`hosted`) it finds the repository (Binder: the
    notebook runs inside it, one folder down) or clones ``repo_url`` (``$NEURALUV_REPO`` overrides it; the
    clone carries the committed ``results/`` the chapters read), pip-installs it with the ``render`` extra
    when ``neuraluv`` is not importable, puts it on ``sys.path`` (an editable install made in a running
    kernel is only seen after a restart) and fetches the meshes (:func:`fetch_data`). Elsewhere it does
    nothing. The cell is plain Python (no ``!pip``) so that a unit test can run it in a simulated hosted
    kernel; ``book/setup_cells.py`` writes it into every notebook.

    Parameters
    ----------
    repo_url : str
        The repository's URL (``repository.url`` of ``book/_config.yml``).
    """
    return f"""# Set-up for a hosted notebook service (Colab, Binder): get neuraluv and the meshes there.
# Anywhere else (a checkout, your own Jupyter) this cell does nothing.
import importlib.util, os, subprocess, sys  # noqa: E401  (the chapter's own imports follow in the next cell)
if "google.colab" in sys.modules or any(os.environ.get(k, "").strip().lower() not in ("", "0", "false", "no")
                                        for k in ("NEURALUV_HOSTED", "COLAB_RELEASE_TAG", "BINDER_LAUNCH_HOST")):
    repo = os.path.abspath("..")  # Binder: the notebook runs inside the repository
    if not os.path.exists(os.path.join(repo, "neuraluv", "__init__.py")):  # Colab: only the notebook came
        repo = os.path.abspath("neuraluv-repo")
        if not os.path.exists(repo):
            subprocess.run(["git", "clone", "--depth", "1", os.environ.get("NEURALUV_REPO", "{repo_url}"), repo],
                           check=True)
    if importlib.util.find_spec("neuraluv") is None:
        subprocess.run([sys.executable, "-m", "pip", "install", "-q", "-e", repo + "[render]"], check=True)
    sys.path.insert(0, repo)  # an install made in a running kernel is only seen after a restart
    subprocess.run([sys.executable, "-c", "from neuraluv.notebook import fetch_data; fetch_data()"], cwd=repo, check=True)"""
