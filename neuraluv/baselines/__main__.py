"""``python -m neuraluv.baselines MESH ...``: a quick table of every baseline on some meshes."""
from neuraluv.baselines.methods import main

if __name__ == "__main__":
    main()
