"""Where a CMake build of this project keeps the Python modules it generates (ax12_table.py,
from firmware/core/ct_items.h: python/CMakeLists.txt), and how a script or test imports them.

ctest hands the Python tests PYTHONPATH; scripts and hand-run tests call use() or ensure().
"""
import importlib.util
import os
import sys

GENERATED = "ax12_table.py"


def python_dir(build):
    """<build tree>/python, for a build folder or any folder inside one (e.g. build/test/core)."""
    here = os.path.abspath(build)
    while not os.path.exists(os.path.join(here, "CMakeCache.txt")):
        parent = os.path.dirname(here)
        if parent == here:
            return os.path.join(os.path.abspath(build), "python")
        here = parent
    return os.path.join(here, "python")


def use(build):
    """Makes the generated modules of this build the ones imported; exits naming the missing
    file when the build has not made them."""
    folder = python_dir(build)
    if not os.path.exists(os.path.join(folder, GENERATED)):
        sys.exit("%s: %s not found: build first (cmake --build %s)"
                 % (os.path.basename(sys.argv[0]), os.path.join(folder, GENERATED), build))
    sys.path.insert(0, folder)


def ensure(default_build):
    """The generated modules as PYTHONPATH gives them (ctest), else those of default_build."""
    if importlib.util.find_spec("ax12_table") is None:
        use(default_build)
