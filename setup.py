"""Build step that pyproject.toml cannot say: a wheel carries the repository's top-level
`policies/` and `curriculum/` folders inside the package (`rllib_pommer/_shipped/`), so the named
policies and curricula work from an installed wheel. An editable install reads the folders in
place and gets no copy. Where the copies go and how they are found: rllib_pommer/util/shipped.py."""

import importlib.util
import shutil
from pathlib import Path

from setuptools import setup
from setuptools.command.build_py import build_py

ROOT = Path(__file__).resolve().parent
_spec = importlib.util.spec_from_file_location("_shipped",
                                               ROOT / "rllib_pommer" / "util" / "shipped.py")
shipped = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(shipped)
# Local training output (policies/*/training/, ignored by git) and caches stay out of the wheel.
SKIP = shutil.ignore_patterns("training", "__pycache__", "*.pyc")


class BuildPyWithData(build_py):
    """build_py, then the data folders copied into the built package."""

    def run(self):
        super().run()
        if getattr(self, "editable_mode", False):
            return
        for folder in shipped.FOLDERS:
            target = Path(self.build_lib) / "rllib_pommer" / shipped.SHIPPED / folder
            shutil.rmtree(target, ignore_errors=True)
            shutil.copytree(ROOT / folder, target, ignore=SKIP)


setup(cmdclass={"build_py": BuildPyWithData})
