"""``python -m neuraluv_paper.baselines MESH ...``: a quick table of every baseline on some meshes."""
from neuraluv_paper.baselines.methods import main

if __name__ == "__main__":
    main()
