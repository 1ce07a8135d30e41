"""The documentation site builds, and every fenced code block in ``docs/*.md`` runs.

Conventions (also stated on the Getting started page):

- ```` ```python ```` blocks of one page run in order in one shared namespace (like a doctest session),
  in a fresh temporary working directory, in a separate Python process (so what a page registers does
  not leak into other tests); a failing block is reported with its page and line, and the page's later
  blocks are reported as not run.
- ```` ```bash ```` / ```` ```console ```` blocks: each line starting with ``tableclean-bench`` or ``python``
  (after an optional ``$ `` prompt; a trailing ``\\`` continues the line) runs as a subprocess in a fresh
  temporary directory and must exit 0; other lines (``pip install``, ``ray start``, ...) are not run.
  ``tableclean-bench`` runs as ``python -m tableclean_suite.bench`` (the console script's own code, so
  the test does not depend on which script an older install left on PATH).
- ```` ```text ```` blocks are output and are not run; ```` ```json ```` blocks must parse.
- A block right after the line ``<!-- test: slow -->`` runs only under the ``slow`` marker (MuJoCo
  physics, or a full-size run).

The temporary directory holds a link to the checkout's ``examples/`` so pages can name
``examples/specs/...`` as a reader in a checkout would.
"""

from __future__ import annotations

import html
import json
import os
import re
import shlex
import subprocess
import sys
import textwrap
from dataclasses import dataclass
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
DOCS = REPO / "docs"
SLOW_COMMENT = "<!-- test: slow -->"
RUNNABLE_PREFIXES = ("tableclean-bench", "python")
LANGUAGES = ("python", "bash", "console", "text", "json")
FENCE = re.compile(r"^(?P<indent>[ ]*)(?P<fence>```+|~~~+)(?P<info>[^`]*)$")
PAGE_TIMEOUT_S = 900  # one page's python blocks (physics pages under the slow marker)
COMMAND_TIMEOUT_S = 900  # one command of a bash block
sys.path.insert(0, str(DOCS / "hooks"))
import api_pages  # noqa: E402  (docs/hooks: the generated API pages)
import command_reference  # noqa: E402  (docs/hooks: the generated command reference)


@dataclass(frozen=True)
class Block:
    """One fenced code block of a docs page."""

    page: str  # file name under docs/, e.g. "getting-started.md"
    line: int  # 1-based line of the opening fence
    language: str  # the fence's info string's first word ("" if none)
    code: str  # the block's text, dedented
    slow: bool  # preceded by SLOW_COMMENT

    @property
    def name(self) -> str:
        return f"{self.page}:{self.line}"


def doc_pages() -> list[Path]:
    """Every Markdown page under docs/ (the generated command and API pages are not files)."""
    return sorted(DOCS.rglob("*.md"))


def page_blocks(path: Path) -> list[Block]:
    """The fenced code blocks of one page, in order."""
    lines = path.read_text(encoding="utf-8").splitlines()
    blocks, index = [], 0
    while index < len(lines):
        opening = FENCE.match(lines[index])
        if not opening:
            index += 1
            continue
        indent, fence, info = opening["indent"], opening["fence"], opening["info"].strip()
        body, end = [], index + 1
        while end < len(lines) and lines[end].strip() != fence:
            body.append(lines[end][len(indent):] if lines[end].startswith(indent) else lines[end])
            end += 1
        if end == len(lines):
            raise ValueError(f"{path.name}:{index + 1}: code fence is never closed")
        previous = next((lines[i].strip() for i in range(index - 1, -1, -1) if lines[i].strip()), "")
        page = str(path.relative_to(DOCS)) if path.is_relative_to(DOCS) else path.name
        blocks.append(Block(page, index + 1, info.split()[0] if info else "",
                            textwrap.dedent("\n".join(body)) + "\n", previous == SLOW_COMMENT))
        index = end + 1
    return blocks


def all_blocks() -> list[Block]:
    return [block for page in doc_pages() for block in page_blocks(page)]


def command_lines(block: Block) -> list[str]:
    """The lines of a bash/console block that run: those starting with a runnable prefix."""
    joined, pending = [], ""
    for raw in block.code.splitlines():
        line = raw.strip()
        if line.startswith("$ "):
            line = line[2:]
        if line.endswith("\\"):
            pending += line[:-1].rstrip() + " "
            continue
        joined.append(pending + line)
        pending = ""
    return [line for line in joined if line.startswith(RUNNABLE_PREFIXES)]


def _marks(block: Block) -> list:
    marks = [pytest.mark.cli]
    if block.slow:
        marks.append(pytest.mark.slow)
    return marks


def _params(languages: tuple[str, ...]) -> list:
    return [pytest.param(block, id=block.name, marks=_marks(block))
            for block in all_blocks() if block.language in languages]


def _workdir(tmp_path: Path) -> Path:
    """A fresh working directory with the checkout's examples/ linked in."""
    work = tmp_path / "work"
    work.mkdir()
    (work / "examples").symlink_to(REPO / "examples", target_is_directory=True)
    return work


def _environment() -> dict[str, str]:
    env = dict(os.environ)
    env.setdefault("MUJOCO_GL", "egl")
    env["PYTHONHASHSEED"] = "0"
    return env


# ---- python blocks: one process per page ---------------------------------------------------------

#: Runs a page's python blocks in one namespace; writes one result per block to argv[2] as JSON lines.
PAGE_DRIVER = r"""
import json, sys, traceback
blocks = json.load(open(sys.argv[1]))
namespace = {"__name__": "__main__"}
with open(sys.argv[2], "w") as out:
    for block in blocks:
        try:
            exec(compile(block["code"], f"{block['page']}:{block['line']}", "exec"), namespace)
        except BaseException:
            out.write(json.dumps({"line": block["line"], "error": traceback.format_exc()}) + "\n")
            break
        out.write(json.dumps({"line": block["line"], "error": None}) + "\n")
        out.flush()
"""

_page_results: dict[tuple[str, bool], dict[int, str | None]] = {}


def run_python_blocks(blocks: list[Block], workdir: Path) -> dict[int, str | None]:
    """Run ``blocks`` in order in one namespace in a new process; line -> None (ran) or the traceback.
    Blocks after a failing one are missing from the result."""
    spec = workdir / "blocks.json"
    spec.write_text(json.dumps([{"page": b.page, "line": b.line, "code": b.code} for b in blocks]))
    results = workdir / "results.jsonl"
    done = subprocess.run([sys.executable, "-c", PAGE_DRIVER, str(spec), str(results)], cwd=workdir,
                          env=_environment(), capture_output=True, text=True, timeout=PAGE_TIMEOUT_S)
    outcome = {}
    if results.exists():
        for row in results.read_text().splitlines():
            record = json.loads(row)
            outcome[record["line"]] = record["error"]
    if done.returncode != 0 and all(error is None for error in outcome.values()):
        missing = next((b.line for b in blocks if b.line not in outcome), None)
        outcome[missing] = f"the page's process exited with code {done.returncode}:\n{done.stderr[-4000:]}"
    return outcome


def _page_outcome(block: Block, tmp_path_factory) -> dict[int, str | None]:
    """Results of the page's python blocks: without its slow blocks for a fast block, all of them for a
    slow one (a slow block may use what the blocks before it defined); computed once per page and kind."""
    key = (block.page, block.slow)
    if key not in _page_results:
        blocks = [b for b in page_blocks(DOCS / block.page) if b.language == "python" and (block.slow or not b.slow)]
        workdir = _workdir(tmp_path_factory.mktemp("docs_python"))
        _page_results[key] = run_python_blocks(blocks, workdir)
    return _page_results[key]


@pytest.mark.parametrize("block", _params(("python",)))
def test_python_block_runs(block, tmp_path_factory):
    outcome = _page_outcome(block, tmp_path_factory)
    if block.line not in outcome:
        failed = next(line for line, error in outcome.items() if error is not None)
        pytest.fail(f"{block.name} did not run: block {block.page}:{failed} before it failed")
    assert outcome[block.line] is None, f"{block.name} raised:\n{outcome[block.line]}"


# ---- bash / console blocks -------------------------------------------------------------------------

@pytest.mark.parametrize("block", _params(("bash", "console")))
def test_shell_block_runs(block, tmp_path):
    lines = command_lines(block)
    if not lines:
        pytest.skip(f"{block.name} has no line starting with {' or '.join(RUNNABLE_PREFIXES)}")
    workdir = _workdir(tmp_path)
    for line in lines:
        argv = shlex.split(line)
        if argv[0] == "python":
            argv[0] = sys.executable
        elif argv[0] == "tableclean-bench":  # the console script's own code path, whatever is on PATH
            argv = [sys.executable, "-m", "tableclean_suite.bench", *argv[1:]]
        done = subprocess.run(argv, cwd=workdir, env=_environment(), capture_output=True, text=True,
                              timeout=COMMAND_TIMEOUT_S)
        assert done.returncode == 0, (f"{block.name}: `{line}` exited with {done.returncode}:\n"
                                      f"{done.stdout[-2000:]}\n{done.stderr[-4000:]}")


@pytest.mark.parametrize("block", [pytest.param(b, id=b.name) for b in all_blocks() if b.language == "json"])
def test_json_block_parses(block):
    json.loads(block.code)


def test_every_block_names_a_known_language():
    unknown = [f"{b.name} ({b.language or 'no language'})" for b in all_blocks() if b.language not in LANGUAGES]
    assert not unknown, f"fenced blocks need one of {', '.join(LANGUAGES)}: {', '.join(unknown)}"


def test_slow_comment_precedes_a_block():
    """A ``<!-- test: slow -->`` that is not followed by a fence would silently mark nothing."""
    stray = []
    for page in doc_pages():
        lines = page.read_text(encoding="utf-8").splitlines()
        for number, line in enumerate(lines):
            if line.strip() == SLOW_COMMENT:
                following = next((later for later in lines[number + 1:] if later.strip()), "")
                if not FENCE.match(following):
                    stray.append(f"{page.name}:{number + 1}")
    assert not stray, f"{SLOW_COMMENT} not followed by a code block at {', '.join(stray)}"


# ---- the runner catches what it is for ---------------------------------------------------------------

@pytest.mark.cli
def test_a_renamed_function_fails_its_block(tmp_path):
    """A page whose second block calls a name the package does not have fails at that block, and its
    third block is reported as not run."""
    page = tmp_path / "page.md"
    page.write_text("```python\nfrom tableclean_suite.task import TaskModel\n```\n\n"
                    "```python\nfrom tableclean_suite.task import shortest_plan_renamed\n```\n\n"
                    "```python\nmodel = TaskModel()\n```\n")
    blocks = page_blocks(page)
    assert [b.line for b in blocks] == [1, 5, 9]
    outcome = run_python_blocks(blocks, _workdir(tmp_path))
    assert outcome[1] is None
    assert "ImportError" in outcome[5] and "shortest_plan_renamed" in outcome[5]
    assert 9 not in outcome


def test_block_parser_reads_languages_slow_marks_and_continuations(tmp_path):
    page = tmp_path / "page.md"
    page.write_text(f"text\n\n{SLOW_COMMENT}\n```bash\n$ python -m x \\\n    --flag\npip install y\n```\n\n"
                    "```text\noutput\n```\n")
    bash, text = page_blocks(page)
    assert (bash.language, bash.slow, bash.line) == ("bash", True, 4)
    assert command_lines(bash) == ["python -m x --flag"]
    assert (text.language, text.slow) == ("text", False)


# ---- the site ------------------------------------------------------------------------------------

@pytest.fixture(scope="module")
def site(tmp_path_factory):
    """``mkdocs build --strict`` into a temporary folder; the folder."""
    out = tmp_path_factory.mktemp("site")
    env = _environment()
    env["NO_MKDOCS_2_WARNING"] = "1"
    done = subprocess.run([sys.executable, "-m", "mkdocs", "build", "--strict", "--site-dir", str(out)],
                          cwd=REPO, env=env, capture_output=True, text=True, timeout=COMMAND_TIMEOUT_S)
    assert done.returncode == 0, f"mkdocs build --strict failed:\n{done.stderr[-6000:]}"
    return out


@pytest.mark.cli
def test_site_builds_strict_with_every_page(site):
    for page in doc_pages():
        html = site / page.relative_to(DOCS).with_suffix("") / "index.html"
        if page.name == "index.md":
            html = site / page.relative_to(DOCS).parent / "index.html"
        assert html.exists(), f"{page.name} was not built"


#: A Sphinx role or an reST literal-block marker as the built HTML shows it when nothing renders it.
RAW_ROLE = re.compile(r":(?:py:)?(?:func|class|meth|mod|data|attr|obj|exc|const|ref):(?:`|<code>)|\w::</p>")


def test_the_raw_role_pattern_finds_what_an_unrendered_docstring_leaves():
    assert RAW_ROLE.search("see :func:<code>train</code> and") and RAW_ROLE.search("then::</p>")
    assert not RAW_ROLE.search('<a href="#x"><code>train</code></a>: the loop')


@pytest.mark.cli
def test_the_site_shows_no_raw_sphinx_role(site):
    """Docstrings use mkdocstrings' cross-references: no page of the built site shows a raw role."""
    found = [f"{page.relative_to(site)}: {match.group(0)}" for page in sorted(site.rglob("*.html"))
             for match in RAW_ROLE.finditer(page.read_text(encoding="utf-8"))]
    assert not found, f"{len(found)} raw roles, e.g. {found[:5]}"


@pytest.mark.cli
def test_api_reference_documents_every_module(site):
    missing = []
    for page, modules in api_pages.modules_by_page().items():
        html = (site / api_pages.API_FOLDER / Path(page).stem / "index.html").read_text(encoding="utf-8")
        missing += [module for module in modules if f'id="{module}"' not in html]
    assert not missing, f"modules without an API entry: {', '.join(missing)}"


def test_every_module_has_an_api_page():
    modules = api_pages.package_modules()
    assert "tableclean_suite.task.model" in modules and "tableclean_suite.bench.run" in modules
    assert api_pages.page_of("tableclean_suite.task.model") == "task.md"
    assert api_pages.page_of("tableclean_suite.bench.statistics") == "metrics.md"
    assert sum(len(names) for names in api_pages.modules_by_page().values()) == len(modules)
    with pytest.raises(ValueError, match="matches no API page"):
        api_pages.page_of("another_package.module")


def _fresh_command_helps() -> dict[str, str]:
    """Every command's help as a fresh process renders it (this one may hold names other tests
    registered, which the commands list as allowed values)."""
    code = (f"import json, sys; sys.path.insert(0, {str(DOCS / 'hooks')!r}); import command_reference; "
            "print(json.dumps(command_reference.command_helps()))")
    done = subprocess.run([sys.executable, "-c", code], cwd=REPO, env=_environment(), capture_output=True,
                          text=True, timeout=COMMAND_TIMEOUT_S, check=True)
    return json.loads(done.stdout)


@pytest.mark.cli
def test_command_reference_shows_every_commands_help(site):
    """Each command's ``--help``, exactly as its parser prints it, is on the command reference page."""
    page = (site / "commands" / "index.html").read_text(encoding="utf-8")
    shown = html.unescape(re.sub(r"<[^>]+>", "", page))
    helps = _fresh_command_helps()
    assert "run" in helps, f"the command registry lists no 'run' command: {sorted(helps)}"
    missing = [name for name, text in helps.items() if text not in shown]
    assert not missing, f"commands whose --help is not on the page (or differs): {', '.join(missing)}"
    assert command_reference.MARKER not in page


# ---- the README's links into the docs ---------------------------------------------------------

LINK = re.compile(r"\]\((?P<target>[^)\s]+)\)")


def _slug(heading: str) -> str:
    """The anchor MkDocs' toc extension gives a heading (lower case, punctuation dropped, spaces to -)."""
    text = re.sub(r"[^\w\s-]", "", heading.strip().lower())
    return re.sub(r"[\s]+", "-", text)


def _anchors(page: Path) -> set[str]:
    headings = [line.lstrip("#").strip() for line in page.read_text(encoding="utf-8").splitlines()
                if re.match(r"#{1,6} ", line)]
    return {_slug(heading) for heading in headings}


def test_readme_links_point_at_files_and_headings_that_exist():
    readme = REPO / "README.md"
    broken = []
    for match in LINK.finditer(readme.read_text(encoding="utf-8")):
        target = match["target"]
        if target.startswith(("http://", "https://", "mailto:")):
            continue
        path, _, anchor = target.partition("#")
        file = readme if not path else REPO / path
        if not file.exists():
            broken.append(target)
        elif anchor and file.suffix == ".md" and anchor not in _anchors(file):
            broken.append(target)
    assert not broken, f"README links to missing files or headings: {', '.join(broken)}"


def test_heading_slugs_match_mkdocs():
    assert _slug("Cruz et al.'s methods, run here (Table 4)") == "cruz-et-als-methods-run-here-table-4"
    assert _slug("The paper's task model") == "the-papers-task-model"
