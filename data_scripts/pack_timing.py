"""Time the default packer on the islands of real atlases, and count its placements.

    python data_scripts/pack_timing.py [MESH ...] [--trials N]

For each registry mesh (default: spot cow fertility bunny beetle) the atlas is built
once with the shelf packer (the charts, solves and islands are the default atlas's;
the islands handed to the packer are kept under ``$NEURALUV_DATA/pack_islands``), then
:func:`neuraluv.layout.pack.tight_pack` packs them as ``neuraluv atlas`` does (its
default trials and cut attempt), timed alone. Prints seconds, placements (calls of the
raster placer), utilisation and padding per mesh. Compare two commits by running the
script from each (the saved islands are reused).
"""
from __future__ import annotations

import argparse
import pickle
import sys
import time
from pathlib import Path


def islands(name):
    """The islands ``build_atlas`` hands to the tight packer for registry mesh ``name`` (cached)."""
    from neuraluv.datasets import data_dir
    path = Path(data_dir()) / "pack_islands" / f"{name}.pkl"
    if path.exists():
        return pickle.loads(path.read_bytes())
    import neuraluv.atlas.build as build
    from neuraluv.datasets import load_raw
    from neuraluv.layout.pack.shelf import shelf_pack

    cap = {}

    def capture(uvs, faces, **kw):
        cap.update(uvs=uvs, faces=faces, kw=kw)
        return shelf_pack(uvs, faces, padding=kw["padding"], resolution=kw["resolution"])

    real, build.tight_pack = build.tight_pack, capture
    try:
        build.build_atlas(*load_raw(name), threads=1)
    finally:
        build.tight_pack = real
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_bytes(pickle.dumps(cap))
    return cap


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("meshes", nargs="*", default=["spot", "cow", "fertility", "bunny", "beetle"])
    p.add_argument("--trials", type=int, default=None, help="packing trials (default: the CLI's)")
    a = p.parse_args(argv)
    import neuraluv.layout.pack.raster as raster
    from neuraluv.layout.pack.tight import tight_pack

    calls = [0]
    place = raster._place

    def counted(*args, **kw):
        calls[0] += 1
        return place(*args, **kw)

    raster._place = counted
    total = 0.0
    for name in a.meshes:
        cap = islands(name)
        kw = dict(cap["kw"], **({"trials": a.trials} if a.trials else {}))
        calls[0] = 0
        t = time.perf_counter()
        r = tight_pack(cap["uvs"], cap["faces"], **kw)
        dt = time.perf_counter() - t
        total += dt
        print(f"{name:10s} {len(cap['uvs']):4d} islands: {dt:6.1f} s, {calls[0]:4d} placements, utilisation "
              f"{100 * r.utilisation:.2f}%, padding {r.padding_texels:.2f} texels, cut {bool(r.pieces)}", flush=True)
    print(f"total {total:.1f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
