#!/usr/bin/env python
"""Fetch the real meshes of the data registry into the neuraluv cache.

    python data_scripts/fetch.py                      # download every mesh (pooch)
    python data_scripts/fetch.py camel_b hand         # only these
    python data_scripts/fetch.py --from ../shared/data/meshes   # offline import, sha256-checked
    python data_scripts/fetch.py --authored --from ../shared/data/authored   # the authored UV layouts

The cache is ``neuraluv.datasets.data_dir()``: ``$NEURALUV_DATA``, else this checkout's ``.cache/neuraluv-data``
(the folder ``make data`` fills and the library reads by default), else the user cache. Nothing tracked by git is
written. The compact charts (camel, hand, bob) are derived
from the fetched files at load time (``neuraluv.datasets.load``), exactly as
the data's SOURCES.md describes.
"""
import argparse
import sys

from neuraluv import datasets


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("names", nargs="*", help="registry names (default: all)")
    p.add_argument("--from", dest="source", help="local mirror folder to import from")
    p.add_argument("--no-download", action="store_true", help="never touch the network")
    p.add_argument("--authored", action="store_true", help="the authored assets with UV layouts instead")
    a = p.parse_args(argv)
    if a.authored:
        res = datasets.fetch_authored(a.source, download=not a.no_download)
        bad = [n for n, v in res.items() if isinstance(v, str)]
        for n, v in res.items():
            print(f"{n:32s} {'ok   ' if not isinstance(v, str) else 'FAIL ' + v}")
        print(f"{len(res) - len(bad)}/{len(res)} authored assets in {datasets.data_dir() / 'authored'}")
        return 1 if bad else 0
    res = datasets.fetch_all(a.source, a.names or None, download=not a.no_download)
    bad = [n for n, v in res.items() if isinstance(v, str)]
    for n, v in res.items():
        print(f"{n:18s} {'ok   ' + str(v) if not isinstance(v, str) else 'FAIL ' + v}")
    print(f"{len(res) - len(bad)}/{len(res)} meshes in {datasets.data_dir()}")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
