"""``python -m nld``: the nld command line."""
import sys

from nld.cli import main

if __name__ == "__main__":
    sys.exit(main())
