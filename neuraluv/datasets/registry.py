"""The registry of real meshes and the paper's compact charts.

Procedural charts are generated in code (no download) and used by the tests,
the demo and the notebooks. Real meshes are listed in :data:`REGISTRY` with their
upstream URL and sha256; :func:`fetch` downloads them with pooch, or imports them
from a local mirror after checking the hash. They are cached in one folder,
:func:`data_dir` (``$NEURALUV_DATA``; else the source checkout's
``.cache/neuraluv-data``, where ``make data`` puts them; else the user cache
directory), never in the repository. Nothing falls back to a procedural chart
when a real mesh is missing: :class:`DataMissing` says, in one line, what to run.
"""
from __future__ import annotations

import hashlib
import os
import shutil
from pathlib import Path

import numpy as np
import pooch

from neuraluv.datasets.procedural import PROCEDURAL, procedural
from neuraluv.errors import NeuralUVError
from neuraluv.io import load_mesh, read_obj
from neuraluv.meshfix import repair_mesh
from neuraluv.topology import components

__all__ = [
    "REGISTRY", "COMPACT", "CLOSED", "LARGE", "data_dir", "fetch", "fetch_all", "available", "load", "load_raw",
    "load_charts", "DataMissing", "FETCH_HINT", "checkout",
]


class DataMissing(NeuralUVError):
    """A registry mesh is not in the cache (fetch it first); the message is one line naming the command."""


#: What to run when a real mesh is missing (in a checkout; an installed package has ``neuraluv data fetch``).
FETCH_HINT = "run `make data` in the repository (or `neuraluv data fetch`)"


_LIBIGL = "https://github.com/libigl/libigl-tutorial-data/raw/c1f9ede366d02e3531ecbaec5e3769312f31cccd/"
_CRANE = "https://github.com/NVlabs/nvdiffrec/raw/a3e73909a01887c8a135235ff860dd23a045cc1b/data/"
_ACJ = "https://github.com/alecjacobson/common-3d-test-models/raw/8a4f8642acaf43f9cd7b67858a1502e1055ef202/data/"

#: Real meshes: name -> (file name, upstream URL, sha256, licence note).
REGISTRY = {
    name: (fname, url, sha, lic)
    for name, fname, url, sha, lic in [
        ("3holes", "3holes.off", _LIBIGL + "3holes.off", "e8b1038cc70d11f393d8894ac08a5106293c50e95a5a60f0d5a8c8a7e884d106", "libigl tutorial data"),
        ("arm", "arm.obj", _LIBIGL + "arm.obj", "b7493c060434374a443501b2b5acb71288cbcaf6a3c42a52fcfc09f4dc5ef57c", "libigl tutorial data"),
        ("beetle", "beetle.off", _LIBIGL + "beetle.off", "aaddee826c2ebec84ab5da51e3fbec47def4909db18cdfd7000d7b5d9c635cf1", "libigl tutorial data"),
        ("bob_tri", "bob_tri.obj", _CRANE + "bob/bob_tri.obj", "2b15031b59c79c5e48a68dba17a13ec081bc62e359fb808a768312a6f41be406", "Keenan Crane, CC0 1.0"),
        ("bunny", "bunny.off", _LIBIGL + "bunny.off", "dda85ca6dc03ed83a0b754611d5c0b1a3c8ba5234e690479ac4a04063e6a7d4d", "libigl tutorial data"),
        ("camel_b", "camel_b.obj", _LIBIGL + "camel_b.obj", "91f7a9a22a273e3dc4c9eab85674ac2a04355f21699a18032f2d5f1f7a7f62c4", "libigl tutorial data"),
        ("camelhead", "camelhead.off", _LIBIGL + "camelhead.off", "bdafbd6330d698483b7b12945bbeee689a1bf998882e7baa61e00de963afd301", "libigl tutorial data"),
        ("cheburashka", "cheburashka.off", _LIBIGL + "cheburashka.off", "f9b087181fbc0c407ab1ae0df4441cc83f31717ab98a0c99e436d35cef8151b1", "libigl tutorial data"),
        ("cow", "cow.off", _LIBIGL + "cow.off", "8834713b505f9bf78c7f7c8b719d51d885d7d059952698da006813d292d84e95", "libigl tutorial data"),
        ("decimated-knight", "decimated-knight.off", _LIBIGL + "decimated-knight.off", "40aa1c53a81d6ad3b0f42023b1d78144488ff0a42afe3821e034d890ad9cffe2", "libigl tutorial data"),
        ("decimated-max", "decimated-max.obj", _LIBIGL + "decimated-max.obj", "e7489f9987a384f582c632ba19d8e6185e749909ef197215eb0c768597678532", "libigl tutorial data"),
        ("elephant", "elephant.obj", _LIBIGL + "elephant.obj", "f1038147fa61efd8b3213d119c682279ffea3cf06cc1713ae2a8ff81e68ba671", "libigl tutorial data"),
        ("face", "face.obj", _LIBIGL + "face.obj", "4817c60799fb7f5ae7f46d27fc48e8c6cbd6b5c7dec7f8197fb794802665a826", "libigl tutorial data"),
        ("fertility", "fertility.off", _LIBIGL + "fertility.off", "145fdfb007c8d5d09ba60943f14f4ddc9edd4327c7956fe379c624adeb59dc5b", "libigl tutorial data"),
        ("hand", "hand.mesh", _LIBIGL + "hand.mesh", "7178db13e578ce00983eef71674879463e5c9dc532d39dfabf84fbd809b983ea", "libigl tutorial data"),
        ("horse_quad", "horse_quad.obj", _LIBIGL + "horse_quad.obj", "f266409b006dd339125dab91c3ca6aefe7289a03c7cf5848b985fcb19ae3de93", "libigl tutorial data"),
        ("lion", "lion.off", _LIBIGL + "lion.off", "eff3b6021044aeae2d64c147cc0ad4ee16042e16c2c5d336efa86031cc815df4", "libigl tutorial data"),
        ("spot", "spot.obj", _CRANE + "spot/spot.obj", "54a49192005e4310dceeb5e5bc6c869fd801998a2cfa930674b60ca00a2fe54d", "Keenan Crane, CC0 1.0"),
        ("fandisk", "fandisk.obj", _ACJ + "fandisk.obj", "ea5bab2fbf545b1915f0d9faf6cc61ff8c18e0d8174ad61f8e35de15d8f6e3f8", "CAD part (Hoppe), common-3d-test-models"),
        ("beast", "beast.obj", _ACJ + "beast.obj", "74c5fecd883b761bc1b2bb6c82fe94d3b3b450297ab561e83c0e63c7ed46abe8", "Autodesk model, common-3d-test-models"),
        ("stanford-bunny", "stanford-bunny.obj", _ACJ + "stanford-bunny.obj", "1eb35d1e21ce99e5ce911353b6be278990713448dd9e8f5c9387f9de39b32205", "Stanford 3D scanning repository"),
        ("nefertiti", "nefertiti.obj", _ACJ + "nefertiti.obj", "19e39748b145092878cc4faafd050505eb5991c5d3e497be2b4575673fa87968", "Egyptian Museum Berlin scan (Thingiverse 3974391)"),
        ("ogre", "ogre.obj", _ACJ + "ogre.obj", "b72e270246ec3bd91bd8e082c4acf462352680f09067813322903b4e1a3f6967", "Kiaran Ritchie, common-3d-test-models"),
    ]
}

#: Real authored assets with UV layouts (and their material and texture files), the development set of
#: ``check --uv`` / ``repair``: file name -> (upstream URL or None, sha256, licence note). Cached under
#: ``data_dir() / "authored"``; the Blender-made layouts have no URL (import them from a mirror).
_TRIMESH = "https://raw.githubusercontent.com/mikedh/trimesh/a513c0e/models/"
AUTHORED = {
    fname: (url, sha, lic)
    for fname, url, sha, lic in [
        ('BoxTextured.glb', _TRIMESH + 'BoxTextured.glb', "cb5dbde10719fc84c2f2db4a071d9f64a1a679488a28f2c98765d0611ad5e0d1", 'Khronos glTF sample model by Cesium, CC-BY 4.0'),
        ('CesiumMilkTruck.glb', _TRIMESH + 'CesiumMilkTruck.glb', "2f17d0f4f48f23cf9d6c8d117e8f5a9ab3e2374dfd8b2e207506438c2c0b0b84", 'Khronos glTF sample model by Cesium, CC-BY 4.0'),
        ('Duck.glb', _TRIMESH + 'Duck.glb', "65bf938f54d6073e619e76e007820bbf980cdc3dc0daec0d94830ffc4ae54ab5", 'Khronos glTF sample model, SCEA Shared Source License 1.0'),
        ('bl_cube_shifted_outside.obj', None, "ec13b322efe9bff2916bac32b3f71985cb0ea226b288d84c090b3f5044350af9", 'made with Blender 4.5 by make_blender_layouts.py (spot: Keenan Crane, CC0)'),
        ('bl_cylinder_array_stacked.obj', None, "c9849463fb3a04e3016828af4289aa27c2a73b6a096ff970a69ce33c22dcd6b5", 'made with Blender 4.5 by make_blender_layouts.py (spot: Keenan Crane, CC0)'),
        ('bl_floor_tiled_x4.obj', None, "5ce3d157a9fa6da4ad97b92b1f7c11aa158f243f91dd9e50a4c91c7c58e120bc", 'made with Blender 4.5 by make_blender_layouts.py (spot: Keenan Crane, CC0)'),
        ('bl_spot_seams_unwrap.obj', None, "5199875fc7ee118abf866fb9a35694caeeb53b58cdaa4c7ea821eb245fde3d0e", 'made with Blender 4.5 by make_blender_layouts.py (spot: Keenan Crane, CC0)'),
        ('bl_spot_udim.obj', None, "3b2e9e525aff53bf7a86dd3d2cc2256f1857cc910c43d914c10c44c5e0e00292", 'made with Blender 4.5 by make_blender_layouts.py (spot: Keenan Crane, CC0)'),
        ('bl_suzanne_mirrored_halves.obj', None, "327eb4a33aca65688fb04690da8b1cdfaa31d356637b05ae6043d69742e5fb48", 'made with Blender 4.5 by make_blender_layouts.py (spot: Keenan Crane, CC0)'),
        ('box.obj', _TRIMESH + 'box.obj', "918234c1c9166cce4e9a463d7057a59b5b7cfe40a5f4f9240740c79b7a9fa4a9", 'trimesh test models (MIT repository)'),
        ('capsule.mtl', _TRIMESH + 'capsule.mtl', "e1bae6e1abc5284983179b8260a16e03dfa5e5264aaac288df16958feeeec910", 'trimesh test models (MIT repository)'),
        ('capsule.obj', _TRIMESH + 'capsule.obj', "7e4e244a290331c5f4f3590b0114b30e70cd78dd8211780ba818b573ad45999f", 'trimesh test models (MIT repository)'),
        ('capsule0.jpg', _TRIMESH + 'capsule0.jpg', "e7d1ab42a5b584779d0df0cde43ca3f71629fe84c3a5bca7988b19a6243d2837", 'trimesh test models (MIT repository)'),
        ('chair_model.obj', _TRIMESH + 'chair_model.obj', "7707885a613f733749912dc182ab7172b7498e5fe62810bb1951017612fb8b05", 'trimesh test models (MIT repository)'),
        ('fuze uv.jpg', _TRIMESH + 'fuze uv.jpg', "4a4466ec7fec60a5ee2a29e7dac2b5c0c78d57b4a20ba1c8f6471689561acee3", 'trimesh test models (MIT repository)'),
        ('fuze.obj', _TRIMESH + 'fuze.obj', "a42779b57af5969baf8a08fd2194f57d5a87882ddc1f2dfcce05f99519e7ce60", 'trimesh test models (MIT repository)'),
        ('fuze.obj.mtl', _TRIMESH + 'fuze.obj.mtl', "cbaad4842d5096786240908be7fcb0c43256799fe543fec050bc91ffb2cc8b40", 'trimesh test models (MIT repository)'),
        ('ico4uv.mtl', _TRIMESH + 'ico4uv.mtl', "6e35bcf7fe06b2a05c3c8e8456c4b14d41728cb454a2aa426833a2c504baf3aa", 'trimesh test models (MIT repository)'),
        ('ico4uv.obj', _TRIMESH + 'ico4uv.obj', "740a4eadbc7de49ca5367a8287de0a63a50684ca4c942d8bcb0064ed817cf933", 'trimesh test models (MIT repository)'),
        ('textured_tetrahedron.obj', _TRIMESH + 'textured_tetrahedron.obj', "0e64cfad3260b78676dccd65b64eb06bd8fd72fe496f38df43c8891719b922ca", 'trimesh test models (MIT repository)'),
        ('tube.obj', _TRIMESH + 'tube.obj', "933aa18c58fb88adcb6ce36fdfa418e59902b54519a99e35f17ccdc107d01506", 'trimesh test models (MIT repository)'),
        ('wallhole.obj', _TRIMESH + 'wallhole.obj', "1fbc5796c69f440c9f1e4052d3044095e9ec742a92cac4f909c7301f39c4e654", 'trimesh test models (MIT repository)'),
    ]
}

#: The paper's compact charts: name -> registry mesh they are derived from.
COMPACT = {"camel": "camel_b", "hand": "hand", "bob": "bob_tri"}

#: Registry meshes that are closed surfaces (atlas and chart-cutting inputs).
CLOSED = ["bunny", "cow", "spot", "elephant", "arm", "fertility", "cheburashka", "decimated-knight", "lion", "beetle", "3holes"]

#: The large meshes (13k–124k faces): the size-stratified chart benchmark and atlas timing.
LARGE = ["fandisk", "beast", "stanford-bunny", "nefertiti", "ogre"]


def checkout():
    """The source checkout this package runs from (an editable install or ``PYTHONPATH``), or None when installed."""
    root = Path(__file__).resolve().parents[2]
    return root if (root / "pyproject.toml").is_file() and (root / "Makefile").is_file() else None


def data_dir():
    """The one data folder, which ``make data``, ``neuraluv data fetch`` and every loader use.

    ``$NEURALUV_DATA`` when set; else, when the package runs from a source checkout,
    the checkout's ``.cache/neuraluv-data`` (so Jupyter or pytest started anywhere
    find what ``make data`` fetched); else the user cache (``pooch.os_cache``).
    """
    env = os.environ.get("NEURALUV_DATA")
    if env:
        return Path(env).expanduser()
    root = checkout()
    if root is not None:
        return root / ".cache" / "neuraluv-data"
    return Path(pooch.os_cache("neuraluv"))


def _sha256(path):
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        for chunk in iter(lambda: fh.read(1 << 20), b""):
            h.update(chunk)
    return h.hexdigest()


def _entry(name):
    if name not in REGISTRY:
        raise NeuralUVError(f"unknown registry mesh {name!r}; known: {', '.join(sorted(REGISTRY))}")
    return REGISTRY[name]


def available(name):
    """True when registry mesh ``name`` is in the cache with the right hash."""
    fname, _, sha, _ = _entry(name)
    p = data_dir() / fname
    return p.exists() and _sha256(p) == sha


def fetch(name, source=None, *, download=True):
    """Put registry mesh ``name`` in the cache and return its path.

    Parameters
    ----------
    name : str
        A key of :data:`REGISTRY`.
    source : path-like, optional
        A local mirror folder: the file is copied from there after its sha256 is
        checked (no network needed).
    download : bool
        Without a ``source``, download from the upstream URL with pooch.

    Raises
    ------
    NeuralUVError
        On a hash mismatch; :class:`DataMissing` when the file cannot be had.
    """
    fname, url, sha, _ = _entry(name)
    dest = data_dir() / fname
    if dest.exists() and _sha256(dest) == sha:
        return dest
    dest.parent.mkdir(parents=True, exist_ok=True)
    if source is not None:
        src = Path(source) / fname
        if not src.exists():
            raise DataMissing(f"{fname} not found in {source}")
        got = _sha256(src)
        if got != sha:
            raise NeuralUVError(f"{src}: sha256 {got[:12]}… does not match the registry ({sha[:12]}…); refusing to import")
        tmp = dest.with_suffix(dest.suffix + ".part")
        shutil.copyfile(src, tmp)
        os.replace(tmp, dest)
        return dest
    if not download:
        raise DataMissing(f"the real mesh {name!r} is not in {data_dir()}: {FETCH_HINT}")

    try:
        return Path(pooch.retrieve(url, known_hash=f"sha256:{sha}", fname=fname, path=dest.parent, progressbar=False))
    except Exception as exc:  # network errors, hash mismatch
        raise DataMissing(f"could not download {name!r} ({type(exc).__name__}); use `--from DIR` with a local mirror") from None


def fetch_all(source=None, names=None, download=True):
    """Fetch several registry meshes; returns ``{name: path or error message}``."""
    out = {}
    for name in names or sorted(REGISTRY):
        try:
            out[name] = fetch(name, source, download=download)
        except NeuralUVError as exc:
            out[name] = str(exc)
    return out


def authored_path(fname):
    """Path of the authored asset ``fname`` in the cache (:data:`AUTHORED`), or :class:`DataMissing`."""
    if fname not in AUTHORED:
        raise NeuralUVError(f"unknown authored asset {fname!r}; known: {', '.join(sorted(AUTHORED))}")
    p = data_dir() / "authored" / fname
    if not p.exists():
        raise DataMissing(f"authored asset {fname!r} is not cached; run `python data_scripts/fetch.py --authored "
                          "--from DIR` (or without --from, to download)")
    return p


def fetch_authored(source=None, *, download=True):
    """Put every authored asset (:data:`AUTHORED`) in ``data_dir() / "authored"``: ``{file: path or error}``.

    Parameters
    ----------
    source : path-like, optional
        A local mirror folder (sha256-checked copies); without it, the assets with a URL are downloaded.
    download : bool
    """
    out = {}
    dest_dir = data_dir() / "authored"
    dest_dir.mkdir(parents=True, exist_ok=True)
    for fname, (url, sha, _) in sorted(AUTHORED.items()):
        dest = dest_dir / fname
        try:
            if dest.exists() and _sha256(dest) == sha:
                out[fname] = dest
                continue
            if source is not None and (Path(source) / fname).exists():
                src = Path(source) / fname
                got = _sha256(src)
                if got != sha:
                    raise NeuralUVError(f"{src}: sha256 {got[:12]}… does not match the registry ({sha[:12]}…)")
                tmp = dest.with_name(dest.name + ".part")
                shutil.copyfile(src, tmp)
                os.replace(tmp, dest)
                out[fname] = dest
            elif url and download:
                out[fname] = Path(pooch.retrieve(url, known_hash=f"sha256:{sha}", fname=fname, path=dest_dir,
                                                 progressbar=False))
            else:
                raise DataMissing(f"{fname}: not in the mirror" + ("" if url else " (made in Blender: no URL)"))
        except Exception as exc:  # noqa: BLE001 - one line per asset
            out[fname] = str(exc) if isinstance(exc, NeuralUVError) else f"{fname}: {type(exc).__name__}"
    return out


def load_raw(name):
    """Load a cached registry mesh as ``(V, F)`` (no download)."""
    return load_mesh(fetch(name, download=False))


def _derive_hand():
    V, F = load_raw("hand")  # boundary surface of the tet mesh, unreferenced removed
    y = V[:, 1]
    cy = V[F, 1].mean(axis=1)
    cut = y.min() + 0.04 * (y.max() - y.min())
    F = F[cy > cut]
    V, F, _, _ = repair_mesh(V, F)
    return V, F


def _derive_bob():
    V, F, UV, FUV = read_obj(fetch("bob_tri", download=False))
    if FUV is None:
        raise NeuralUVError("bob_tri.obj has no texture coordinates to split along")
    Vc = np.zeros((len(UV), 3))
    Vc[FUV.reshape(-1)] = V[F.reshape(-1)]
    used = np.unique(FUV)
    remap = -np.ones(len(UV), np.int64)
    remap[used] = np.arange(len(used))
    return Vc[used], remap[FUV]


def load(name):
    """Load a chart by name: a procedural one, a compact chart or a registry mesh.

    Parameters
    ----------
    name : str
        ``"camel"``, ``"hand"``, ``"bob"`` (the paper's compact charts, derived
        as in ``SOURCES.md``), a :data:`REGISTRY` key, or a :data:`PROCEDURAL` key.

    Returns
    -------
    V : (n,3) float array
    F : (m,3) int array

    Raises
    ------
    DataMissing
        When a real mesh is not cached yet.
    """
    if name in PROCEDURAL:
        return procedural(name)
    if name == "camel":
        return load_raw("camel_b")
    if name == "hand":
        return _derive_hand()
    if name == "bob":
        return _derive_bob()
    return load_raw(name)


def load_charts(name, *, largest=False):
    """A chart by name, split into its disk-like components (Bob has three).

    Parameters
    ----------
    name : str
        As for :func:`load`.
    largest : bool
        Return only the largest component (the NTK probes' "Bob chart").

    Returns
    -------
    list of (V, F)
        One stand-alone mesh per connected component, largest first.

    Examples
    --------
    >>> [F.shape[0] for _, F in load_charts("components")]
    [216, 216, 216]
    """
    V, F = load(name)
    parts = [(V[vi], Fc) for vi, _, Fc in components(V, F)]
    return parts[:1] if largest else parts
