"""Data flows one way: game -> agents -> data/imitation/arena -> rl -> jobs. A module may not
import the heavy packages a layer above it brings in; the top level of the package holds the jobs
alone."""

from __future__ import annotations

import ast
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
import tomllib

PACKAGE = Path(__file__).resolve().parents[1] / "rllib_pommer"


def _loaded(modules: list[str], heavy: tuple[str, ...], then: str = "") -> str:
    """The `heavy` packages loaded after importing `modules` and running `then`, in a fresh
    interpreter."""
    code = (f"import sys, {', '.join(modules)}\n{then}\n"
            f"print(','.join(m for m in {heavy!r} if m in sys.modules))")
    return subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          check=True).stdout.strip()


def _package_modules(package: str) -> list[str]:
    return [f"rllib_pommer.{package}.{path.stem}"
            for path in sorted((PACKAGE / package).glob("*.py")) if path.stem != "__init__"]


def test_util_is_standard_library_only():
    """util/ may be imported from any layer, so it brings in nothing: no third-party package and
    no module of ours outside util/."""
    modules = _package_modules("util")
    code = (f"import sys\nbefore = set(sys.modules)\nimport {', '.join(modules)}\n"
            "print(','.join(sorted(m for m in set(sys.modules) - before "
            "if m.split('.')[0] not in sys.stdlib_module_names "
            "and m not in ('rllib_pommer', '__mp_main__') "  # multiprocessing's alias of __main__
            "and not m.startswith('rllib_pommer.util'))))")
    assert subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          check=True).stdout.strip() == ""


def test_the_top_level_holds_the_jobs_alone():
    """Library code lives in the packages; each top-level module is a job with its command."""
    scripts = tomllib.loads((PACKAGE.parent / "pyproject.toml").read_text())["project"]["scripts"]
    jobs = {target.split(":")[0].removeprefix("rllib_pommer.") for target in scripts.values()}
    top = {path.stem for path in PACKAGE.glob("*.py")} - {"__init__"}
    assert top == jobs


def test_user_envs_do_not_import_ray_or_torch():
    """The PettingZoo and Gymnasium envs, built and stepped with SimpleAgent seats."""
    play = ("import gymnasium; env = gymnasium.make('rllib_pommer/PommeTeam-v0'); "
            "env.reset(seed=0); env.step(0); "
            "pz = rllib_pommer.envs.parallel_env(); pz.reset(seed=0); "
            "pz.step(dict.fromkeys(pz.agents, 0))")
    assert _loaded(["rllib_pommer.envs"], ("ray", "torch"), play) == ""


def test_curricula_are_checked_without_ray_or_torch(tmp_path):
    """The run's names, the seat mapping and the curriculum checker: every shipped curriculum,
    and one naming a learned policy (its kind's torch code is not needed to check the name)."""
    learned = tmp_path / "learned.toml"
    learned.write_text('[[stage]]\nname = "x"\nopponent = "imitation"\nepisodes = 5\n')
    check = ("from rllib_pommer.curriculum.curriculum import curriculum_names, load_curriculum\n"
             "from rllib_pommer.curriculum.mapping import SeatMapping\n"
             f"loaded = [load_curriculum(n) for n in curriculum_names() + [{str(learned)!r}]]\n"
             "assert loaded[-1].stages[0].opponent == 'imitation' and len(loaded) > 3\n"
             "SeatMapping(0, 'suicide', 'simple')")
    modules = ["rllib_pommer.curriculum.names", "rllib_pommer.curriculum.curriculum",
               "rllib_pommer.curriculum.mapping"]
    assert _loaded(modules, ("ray", "torch", "gymnasium"), check) == ""


def test_the_report_job_runs_without_ray():
    assert _loaded(["rllib_pommer.report"], ("ray",)) == ""


def test_nothing_below_rl_imports_rl():
    """Data flows one way: the game, agents, data, imitation, arena and the user envs never
    reach up into rl/, not even its Ray-free modules (the reward modes are the game's)."""
    packages = ("game", "agents", "data", "imitation", "arena", "envs")
    modules = [m for p in packages for m in _package_modules(p)] + ["rllib_pommer.envs"]
    code = (f"import sys, {', '.join(modules)}\n"
            "print(','.join(sorted(m for m in sys.modules if m.startswith('rllib_pommer.rl'))))")
    assert subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          check=True).stdout.strip() == ""


# Every import of our own package, against the table of docs/architecture.md.

TABLE_HEADING = "## Who may import whom"
JOBS = "*.py"  # the table's name for the top-level modules, the jobs
ANY = "*"


def import_table(doc: Path) -> dict[str, set[str]]:
    """Package -> the packages it may import, from the Markdown table under `TABLE_HEADING`:
    each row names a package (`game/`, or `*.py` for the jobs) and, in backquotes, the packages
    it may import (`*`: any)."""
    section = doc.read_text().split(TABLE_HEADING, 1)[1].lstrip("\n")
    rows = section[section.index("\n|"):].strip("\n").split("\n\n", 1)[0]  # the first table
    table = {}
    for line in rows.splitlines():
        cells = [cell.strip() for cell in line.strip().strip("|").split("|")]
        if len(cells) != 2 or not cells[0].startswith("`"):
            continue  # the header and its rule
        names = [re.findall(r"`([^`]+)`", cell) for cell in cells]
        table[names[0][0].rstrip("/")] = {name.rstrip("/") for name in names[1]}
    return table


def _layer(parts: list[str], package: Path) -> str:
    """The table's name for the module `parts` below the package: its package, or `JOBS` for a
    top-level module or the package itself."""
    return parts[0] if parts and (package / parts[0]).is_dir() else JOBS


def _is_module(parts: list[str], package: Path) -> bool:
    path = package.joinpath(*parts)
    return path.is_dir() or path.with_suffix(".py").is_file()


def _imported(node: ast.Import | ast.ImportFrom, module: list[str], package: Path
              ) -> list[list[str]]:
    """The modules of ours an import statement names, as parts below the package, relative
    imports resolved (`module`: the importing module's parts, a package as its `__init__`);
    `from X import name` names the submodule X.name where there is one, else X."""
    if isinstance(node, ast.Import):
        names = [alias.name.split(".") for alias in node.names]
    else:
        if node.level:
            target = module[: len(module) - node.level] + (node.module or "").split(".")
        else:
            target = node.module.split(".")
        target = [part for part in target if part]
        names = [target + [alias.name] if _is_module(target[1:] + [alias.name], package)
                 else target for alias in node.names]
    return [name[1:] for name in names if name[0] == package.name]


def import_violations(package: Path, table: dict[str, set[str]]) -> list[str]:
    """Every import of `package`'s own modules, at any depth of any module (inside functions
    too), that the table does not allow, as "file:line: layer imports module"."""
    found = []
    for path in sorted(package.rglob("*.py")):
        module = list(path.relative_to(package.parent).with_suffix("").parts)
        layer = _layer(module[1:-1] if module[-1] == "__init__" else module[1:], package)
        allowed = table.get(layer, set())
        for node in ast.walk(ast.parse(path.read_text(), str(path))):
            if not isinstance(node, (ast.Import, ast.ImportFrom)):
                continue
            for name in _imported(node, module, package):
                target = _layer(name, package)
                if target != layer and target not in allowed and ANY not in allowed:
                    found.append(f"{path.relative_to(package.parent)}:{node.lineno}: {layer}/ "
                                 f"imports {'.'.join([package.name, *name])}")
    return found


DOC = PACKAGE.parent / "docs" / "architecture.md"


def test_the_table_names_every_package():
    table = import_table(DOC)
    packages = {path.name for path in PACKAGE.iterdir()
                if path.is_dir() and (path / "__init__.py").is_file()}
    assert set(table) == packages | {JOBS}
    assert all(names <= set(table) | {ANY} for names in table.values()), table


def test_every_import_of_our_package_is_one_the_table_allows():
    assert import_violations(PACKAGE, import_table(DOC)) == []


def test_the_checker_resolves_relative_and_nested_imports(tmp_path):
    """A synthetic package: an upward import inside a function, relative or absolute, fails; a
    downward one, `from . import x` and an import of the package itself pass."""
    root = tmp_path / "rllib_pommer"
    for module, text in {
        "__init__.py": "",
        "train.py": "from .rl import names\nfrom . import game\n",
        "game/__init__.py": "from . import step\n",
        "game/step.py": "import os\n\ndef f():\n    from ..rl import names\n    return names\n",
        "game/seed.py": "def g():\n    import rllib_pommer.rl.names\n    from .. import train\n",
        "rl/__init__.py": "",
        "rl/names.py": "from ..game.step import f\nfrom rllib_pommer.game import seed\n",
    }.items():
        (root / module).parent.mkdir(parents=True, exist_ok=True)
        (root / module).write_text(text)
    table = {"game": set(), "rl": {"game"}, JOBS: {ANY}}
    assert import_violations(root, table) == [
        "rllib_pommer/game/seed.py:2: game/ imports rllib_pommer.rl.names",
        "rllib_pommer/game/seed.py:3: game/ imports rllib_pommer.train",
        "rllib_pommer/game/step.py:4: game/ imports rllib_pommer.rl.names",
    ]


def test_a_violation_planted_in_a_copy_of_the_package_fails(tmp_path):
    """The collector reaching up into imitation/ again, inside a function as it once did."""
    copy = shutil.copytree(PACKAGE, tmp_path / "rllib_pommer",
                           ignore=shutil.ignore_patterns("__pycache__", "*.pyc", "*.so"))
    collector = copy / "data" / "collector.py"
    planted = "    from ..imitation.learned import greedy_actor"
    text = (f"{collector.read_text()}\n\ndef _actor(name):\n{planted}\n"
            "    return greedy_actor(name)\n")
    collector.write_text(text)
    line = text.splitlines().index(planted) + 1
    assert import_violations(copy, import_table(DOC)) == [
        f"rllib_pommer/data/collector.py:{line}: data/ imports rllib_pommer.imitation.learned"]


def test_test_folders_mirror_the_packages():
    """Tests of one package live in tests/<package>/; only tests across packages (jobs, the
    examples, this file) stay at the top."""
    tests = Path(__file__).resolve().parent
    folders = {path.name for path in tests.iterdir() if (path / "__init__.py").is_file()}
    packages = {path.name for path in PACKAGE.iterdir() if (path / "__init__.py").is_file()}
    assert folders <= packages, sorted(folders - packages)
    assert {"arena", "envs", "imitation", "util"} <= folders



# The map's other two sections: what each package may load, and every module with its job.

LOAD_HEADING = "## What each package may load"
MODULES_HEADING = "## Every module"


def _section(doc: Path, heading: str) -> str:
    """The text of `doc` under `heading`, up to the next heading of the same level."""
    return doc.read_text().split(heading + "\n", 1)[1].split("\n## ", 1)[0]


def load_table(doc: Path) -> list[tuple[list[str], dict[str, bool]]]:
    """The rows of the table under `LOAD_HEADING`: the modules each names (`game/` a package,
    `curriculum/names` a module) and, per heavy package of the header, whether they may load it."""
    lines = [line for line in _section(doc, LOAD_HEADING).splitlines() if line.startswith("|")]
    heavy = [cell.strip().lower() for cell in lines[0].strip("|").split("|")[1:]]
    rows = []
    for line in lines[2:]:
        cells = [cell.strip() for cell in line.strip("|").split("|")]
        if any(cell not in ("yes", "no") for cell in cells[1:]):
            raise ValueError(f"{doc}: {line!r}: each heavy package's cell is yes or no")
        rows.append((re.findall(r"`([^`]+)`", cells[0]),
                     dict(zip(heavy, (cell == "yes" for cell in cells[1:]), strict=True))))
    return rows


def _row_modules(names: list[str], rows: list[tuple[list[str], dict]]) -> list[str]:
    """The importable modules of a row: its named modules, or a package's modules that no
    other row names."""
    named = {name for row, _ in rows for name in row if not name.endswith("/")}
    modules = []
    for name in names:
        if name.endswith("/"):
            package = name.rstrip("/")
            modules += [m for m in _package_modules(package)
                        if m.removeprefix("rllib_pommer.").replace(".", "/") not in named]
        else:
            modules.append("rllib_pommer." + name.replace("/", "."))
    return modules


LOAD_ROWS = load_table(DOC)
LIMITED = [(names, may) for names, may in LOAD_ROWS if not all(may.values())]


@pytest.mark.parametrize("names, may", LIMITED, ids=[" ".join(n) for n, _ in LIMITED])
def test_each_package_loads_only_what_its_row_allows(names, may):
    """Every module of the row imported in a fresh interpreter: no heavy package marked no."""
    modules = _row_modules(names, LOAD_ROWS)
    assert modules, names
    assert _loaded(modules, tuple(name for name, yes in may.items() if not yes)) == ""


def test_the_load_table_covers_every_package():
    packages = {path.name for path in PACKAGE.iterdir() if (path / "__init__.py").is_file()}
    rows = {name.rstrip("/") for names, _ in LOAD_ROWS for name in names if name.endswith("/")}
    assert rows == packages


def mapped_modules(doc: Path) -> list[str]:
    """The modules the bullets under `MODULES_HEADING` name: `game/step`, or a job's `train`."""
    return re.findall(r"^- `([\w/]+)`", _section(doc, MODULES_HEADING), flags=re.MULTILINE)


def package_modules(package: Path) -> set[str]:
    """Every module of `package` as the map names it (`__init__` files aside)."""
    return {str(path.relative_to(package).with_suffix(""))
            for path in package.rglob("*.py") if path.stem != "__init__"}


def test_the_map_names_every_module_once():
    mapped = mapped_modules(DOC)
    assert len(mapped) == len(set(mapped)), sorted(m for m in mapped if mapped.count(m) > 1)
    on_disk = package_modules(PACKAGE)
    assert {"missing from the map": sorted(on_disk - set(mapped)),
            "on the map, gone from the package": sorted(set(mapped) - on_disk)} == {
        "missing from the map": [], "on the map, gone from the package": []}


def test_the_map_check_fails_for_a_new_module(tmp_path):
    copy = shutil.copytree(PACKAGE, tmp_path / "rllib_pommer",
                           ignore=shutil.ignore_patterns("__pycache__", "*.pyc", "*.so"))
    (copy / "game" / "weather.py").write_text('"""Rain on the board."""\n')
    assert package_modules(copy) - set(mapped_modules(DOC)) == {"game/weather"}


# A docstring says what the code does, in the present tense: measurements, with the dates and
# commits they were taken at, belong in docs/measurements.md.
COMMIT_ID = re.compile(r"\b(?=[0-9a-f]*\d)(?=[0-9a-f]*[a-f])[0-9a-f]{7,40}\b")
DATE = re.compile(r"\b20\d\d-[01]\d(-[0-3]\d)?\b")
TIMING = re.compile(r"\b(took|measured|py-spy)\b[^.]{0,60}?\d[\d.,]*\s*(s|ms|%|x)\b")


def diary_entries(package: Path) -> list[str]:
    """Each docstring of `package` (module, class, function) that names a commit, a date or a
    timing taken, as "file:name: the match"."""
    found = []
    for path in sorted(package.rglob("*.py")):
        tree = ast.parse(path.read_text(), str(path))
        nodes = [tree, *(node for node in ast.walk(tree) if isinstance(
            node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)))]
        for node in nodes:
            doc = ast.get_docstring(node) or ""
            for pattern in (COMMIT_ID, DATE, TIMING):
                found += [f"{path.relative_to(package.parent)}:{getattr(node, 'name', '')}: "
                          f"{match.group(0)}" for match in pattern.finditer(doc)]
    return found


def test_docstrings_keep_no_measurement_diary(tmp_path):
    assert diary_entries(PACKAGE) == []
    planted = tmp_path / "rllib_pommer"
    planted.mkdir()
    (planted / "fast.py").write_text(
        '"""Fast.\n\nOn 2026-11-02 (commit 1a2b3c4d) a step took 12.5 ms."""\n')
    assert [entry.split(": ", 1)[1] for entry in diary_entries(planted)] == [
        "1a2b3c4d", "2026-11-02", "took 12.5 ms"]
