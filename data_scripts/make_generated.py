"""Write the seeded set of messy "generated-like" meshes (the Amara-style study inputs).

    python data_scripts/make_generated.py [-n 50] [--seed 0] [-o DIR] [--format obj|ply|glb]

Default folder: $NEURALUV_DATA/generated (never the repository). Each asset is
a pure function of (index, seed) — see neuraluv.datasets.generated — and an
index.json lists the defects applied to each.
"""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path


def main(argv=None):
    from neuraluv.datasets import data_dir
    from neuraluv.datasets.generated import generated_set
    from neuraluv.io import atomic_write

    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("-n", type=int, default=50, help="number of assets (default 50)")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("-o", "--output", default=None, help="folder (default: $NEURALUV_DATA/generated)")
    p.add_argument("--format", default="obj", choices=["obj", "ply", "glb"])
    args = p.parse_args(argv)
    out = Path(args.output) if args.output else Path(data_dir()) / "generated"
    out.mkdir(parents=True, exist_ok=True)
    import trimesh

    index = []
    for V, F, info in generated_set(args.n, args.seed):
        path = out / f"{info['name']}.{args.format}"
        mesh = trimesh.Trimesh(V, F, process=False)  # keep every defect: no merging, no cleanup
        data = mesh.export(file_type=args.format)
        with atomic_write(path, "wb" if isinstance(data, bytes) else "w") as fh:
            fh.write(data)
        info.update({"file": path.name, "vertices": int(len(V)), "faces": int(len(F))})
        index.append(info)
        print(f"{path.name}: {len(V)} vertices, {len(F)} faces, defects: {', '.join(info['defects']) or 'none'}")
    with atomic_write(out / "index.json") as fh:
        json.dump(index, fh, indent=1)
    print(f"wrote {len(index)} assets to {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
