"""Where the shipped policies and curricula are, whatever the install and the working directory.

The repository's top-level `policies/` and `curriculum/` folders are the source (the design card
and the docs name them). A wheel (`pip install .`) carries copies of them inside the package, as
`rllib_pommer/_shipped/<folder>`, made by `setup.py` at build time; a clone or an editable install
has no such copy and reads the repository's folders. An environment variable names another
folder instead (`RLLIB_POMMER_POLICIES`, `RLLIB_POMMER_CURRICULA`).

The search starts from this file, never from the working directory, so a name like `simple` or
`paper` resolves the same from any directory. (A path given by the user, by contrast, is the
user's: relative to where the command runs.) Standard library only: `setup.py` reads this file
too.
"""

from __future__ import annotations

import os
from pathlib import Path

PACKAGE = Path(__file__).resolve().parents[1]
SHIPPED = "_shipped"  # the copies' folder inside the package, in a wheel
# Data folder -> the environment variable that overrides where it is.
FOLDERS = {"policies": "RLLIB_POMMER_POLICIES", "curriculum": "RLLIB_POMMER_CURRICULA"}


def data_dir(folder: str) -> Path:
    """The folder `folder` (a key of FOLDERS) is read from: its variable's value if set, else
    the wheel's copy if there is one, else the repository's top-level folder."""
    override = os.environ.get(FOLDERS[folder])
    if override:
        return Path(override)
    inside = PACKAGE / SHIPPED / folder
    return inside if inside.is_dir() else PACKAGE.parent / folder
