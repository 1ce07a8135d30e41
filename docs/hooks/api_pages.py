"""MkDocs hook: the API reference pages, generated from the package's modules so none is forgotten.

Every module of ``tableclean_suite`` (found by walking the package's folders, so a new module appears
without editing the docs) is assigned to exactly one page of :data:`API_PAGES` by the first rule whose
prefix it matches; each page renders its modules' docstrings with mkdocstrings (``::: module``).
``tests/test_docs.py`` checks that every module lands on a page.
"""

from __future__ import annotations

from pathlib import Path

PACKAGE = "tableclean_suite"
PACKAGE_DIR = Path(__file__).resolve().parents[2] / PACKAGE
API_FOLDER = "api"

#: (page file, title, one-line introduction, module-name prefixes it takes), first match wins.
API_PAGES: tuple[tuple[str, str, str, tuple[str, ...]], ...] = (
    ("task.md", "Task", "Task specifications, states, actions and the task model.", ("tableclean_suite.task",)),
    ("rewards.md", "Rewards", "Reward patterns r1-r4 and your own.", ("tableclean_suite.rewards",)),
    ("metrics.md", "Metrics and statistics",
     "Curves, Table 3's quantities, exact asymptotes, settling, intervals and the scaling fits.",
     ("tableclean_suite.metrics", "tableclean_suite.curves", "tableclean_suite.asymptotes",
      "tableclean_suite.settling", "tableclean_suite.analysis",
      "tableclean_suite.bench.statistics",
      "tableclean_suite.bench.scaling.statistics")),
    ("learners.md", "Learners and backends",
     "train(), the compiled tabular learners, explorations, assistance, where steps come from, and the "
     "resource guard that checks a budget fits before allocating.",
     ("tableclean_suite.learners", "tableclean_suite.backends", "tableclean_suite.resources")),
    ("environments.md", "Environments", "The robosuite environment TableClean and its parts.",
     ("tableclean_suite.environments",)),
    ("controllers.md", "Controllers and skills",
     "Primitives, skills, the skill controller and the compiled control path.",
     ("tableclean_suite.controllers", "tableclean_suite.skill_result")),
    ("gym_envs.md", "Gymnasium environments", "TableCleanSymbolic-v0 and TableCleanSkills-v0.",
     ("tableclean_suite.gym_envs",)),
    ("physics_backend.md", "Physics backend", "Training with the skills in the loop.",
     ("tableclean_suite.physics_backend",)),
    ("demos.md", "Demonstrations", "Demonstration datasets in robomimic's layout.", ("tableclean_suite.demos",)),
    ("executors.md", "Executors", "Local processes and Ray behind one interface.", ("tableclean_suite.executors",)),
    ("bench.md", "Benchmark harness", "The commands and their building blocks.", ("tableclean_suite.bench",)),
    ("package.md", "Package", "The package itself and its shared registry helper.", ("tableclean_suite",)),
)


def package_modules(package_dir: Path = PACKAGE_DIR) -> list[str]:
    """Dotted names of every module and package under ``package_dir`` (``__main__`` files excluded), sorted."""
    names = []
    for path in sorted(package_dir.rglob("*.py")):
        if "__pycache__" in path.parts or path.name == "__main__.py":
            continue
        parts = list(path.relative_to(package_dir.parent).with_suffix("").parts)
        if parts[-1] == "__init__":
            parts.pop()
        names.append(".".join(parts))
    return sorted(names)


def _matches(module: str, prefix: str) -> bool:
    return module == prefix or module.startswith(prefix + ".")


def page_of(module: str) -> str:
    """The API page file (e.g. ``"task.md"``) that documents ``module``; ValueError if no rule takes it."""
    for page, _title, _intro, prefixes in API_PAGES:
        if any(_matches(module, prefix) for prefix in prefixes):
            return page
    raise ValueError(f"module {module!r} matches no API page; add a prefix to API_PAGES")


def modules_by_page(modules: list[str] | None = None) -> dict[str, list[str]]:
    """Page file -> its modules in name order (every page of :data:`API_PAGES`, possibly empty)."""
    pages: dict[str, list[str]] = {page: [] for page, *_ in API_PAGES}
    for module in package_modules() if modules is None else modules:
        pages[page_of(module)].append(module)
    return pages


def page_markdown(page: str, modules: list[str]) -> str:
    """The Markdown of one API page: its title, introduction and one mkdocstrings block per module."""
    title, intro = next((t, i) for p, t, i, _ in API_PAGES if p == page)
    blocks = [f"# {title}", "", intro, ""]
    for module in modules:
        blocks += [f"::: {module}", ""]
    return "\n".join(blocks)


def index_markdown(pages: dict[str, list[str]]) -> str:
    """The API reference's index page: one line per page with the modules it documents."""
    lines = ["# API reference", "",
             "Generated from the docstrings of every module of the package (one page per area).", ""]
    for page, title, intro, _ in API_PAGES:
        names = ", ".join(f"`{m}`" for m in pages[page])
        lines.append(f"- [{title}]({page}): {intro} Modules: {names}")
    return "\n".join(lines) + "\n"


def on_files(files, config):
    """Add the generated API pages to the site's files."""
    from mkdocs.structure.files import File

    pages = modules_by_page()
    files.append(File.generated(config, f"{API_FOLDER}/index.md", content=index_markdown(pages)))
    for page, modules in pages.items():
        files.append(File.generated(config, f"{API_FOLDER}/{page}", content=page_markdown(page, modules)))
    return files
