"""Runs the Python module's tests with pytest (ctest's python_diffreg); exit 77 = skipped."""
import os
import sys

sys.dont_write_bytecode = True  # nothing written into the source tree (no __pycache__)

try:
    import pytest
except ImportError:
    print("skipped: pytest is not installed (Debian: python3-pytest)")
    sys.exit(77)

here = os.path.dirname(os.path.abspath(__file__))
# -p no:cacheprovider: write nothing into the source tree.
sys.exit(pytest.main(["-q", "-p", "no:cacheprovider", here] + sys.argv[1:]))
