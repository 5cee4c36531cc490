"""What twill's plot scripts share: matplotlib without a display, or the agreed exit status.

The program runs each script as `python3 scripts/<script>.py …` (app/python_script.cpp), so
this folder is on the import path. Exit status 3 means matplotlib cannot be imported; twill
turns it into a message naming the package to install.
"""
import sys

MISSING_MATPLOTLIB = 3


def pyplot_or_exit(script):
    """matplotlib.pyplot on the Agg backend (no display needed); exits with status 3 if absent."""
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError as error:
        print(f"{script}: matplotlib is not available ({error})", file=sys.stderr)
        sys.exit(MISSING_MATPLOTLIB)
    return plt
