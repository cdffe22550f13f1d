"""``python -m neuraluv ...`` (the same as the ``neuraluv`` command)."""
import sys

from neuraluv.cli import main

if __name__ == "__main__":
    sys.exit(main())
