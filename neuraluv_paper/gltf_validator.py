"""The Khronos glTF validator (npm ``gltf-validator``; ``make gltf-validator`` installs it into ``.cache/node``),
asked from Python: the benchmark's and the tests' one way to run it on a written file.

It needs ``node``; without it, or without the package, :func:`gltf_validate` answers None and
:func:`validator_missing` says why in one line (a test skips with it, a table says "not run").
"""
from __future__ import annotations

import json
import os
import shutil
import subprocess
from pathlib import Path

__all__ = ["NODE_MODULES", "validator_missing", "gltf_validate"]

_ROOT = Path(__file__).resolve().parents[1]
#: Where ``make gltf-validator`` installs the package (``NEURALUV_NODE_MODULES`` overrides it).
NODE_MODULES = Path(os.environ.get("NEURALUV_NODE_MODULES", _ROOT / ".cache" / "node" / "node_modules"))
_SCRIPT = _ROOT / "data_scripts" / "gltf_validate.js"


def validator_missing():
    """Why the Khronos glTF validator cannot run here (one line), or None."""
    if shutil.which("node") is None:
        return "node is not installed: the Khronos glTF validator cannot run"
    if not (NODE_MODULES / "gltf-validator").exists():
        return "the Khronos glTF validator is not installed (make gltf-validator)"
    if not _SCRIPT.exists():
        return f"{_SCRIPT} is missing (a source checkout has it)"
    return None


def gltf_validate(path, *, timeout=120):
    """The validator's summary of the glTF / GLB ``path``: ``errors``, ``warnings``, ``infos``, ``hints`` and the
    first error and warning ``messages``; None when it cannot run here (:func:`validator_missing`).

    Raises
    ------
    RuntimeError
        The validator ran but printed no summary (a file it could not even parse is a summary with errors).
    """
    if validator_missing():
        return None
    out = subprocess.run(["node", str(_SCRIPT), str(path)], capture_output=True, text=True, timeout=timeout,
                         env={**os.environ, "NODE_PATH": str(NODE_MODULES)})
    try:
        return json.loads(out.stdout)
    except ValueError:
        raise RuntimeError(f"gltf-validator gave no summary for {Path(path).name}: "
                           f"{(out.stdout + out.stderr).strip()[-300:]}") from None
