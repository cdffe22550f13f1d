"""``python -m neuraluv ...`` (the same as the ``neuraluv`` command)."""
from neuraluv.cli import console

if __name__ == "__main__":
    console()
