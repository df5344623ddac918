"""The documentation: the README as a front page, the contributing page's debugging recipe,
and the site (`mkdocs.yml`, `docs/`) built strictly and opened in a browser.

The site's tests need the `docs` extra (`pip install -e '.[docs]'`) and skip, saying so,
without it; the browser test needs Chromium (Debian's `chromium`, which `.ci/run` installs)
and reuses `test_web_viewer.py`'s headless Chromium, driven over the DevTools protocol.
"""

import ast
import functools
import html
import http.server
import importlib.util
import json
import os
import pathlib
import re
import subprocess
import sys
import threading
import time
import tomllib

import numpy as np
import pytest

from test_web_viewer import chromium  # noqa: F401  (the fixture: headless Chromium)

ROOT = pathlib.Path(__file__).resolve().parents[1]
README = ROOT / "README.md"
FIRST_COMMAND = ("python3.11 -m venv .venv && .venv/bin/pip install -e . && "
                 ".venv/bin/lwrl train mountain_car.cost_to_go")
TEST_COMMAND = ("python3.11 -m venv .venv && .venv/bin/pip install -e '.[dev]' && "
                ".venv/bin/python -m pytest -n auto --dist worksteal")
EXTRAS = re.compile(r"pip install[^&]* -e '\.\[([a-z,]+)\]'")
"""The extras of a `pip install -e '.[...]'` command."""
LINK = re.compile(r"!?\[(?:[^\[\]]|\[[^\]]*\])*\]\(([^()\s]+)\)")
WAIT = 60.0
"""Seconds a page may take to load, and its search to answer."""


def hooks():
    """`docs/hooks.py`, the site's hooks, as a module (it imports no MkDocs)."""
    spec = importlib.util.spec_from_file_location("lwrl_docs_hooks", ROOT / "docs" / "hooks.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def readme_commands() -> list[str]:
    """The commands of the README's first code block, its comments left out."""
    block = README.read_text().split("```bash\n", 1)[1].split("```", 1)[0]
    return [line for line in block.splitlines() if line and not line.startswith("#")]


def slug(heading: str) -> str:
    """A heading's anchor as GitHub and MkDocs' toc make it (for the headings used here)."""
    text = re.sub(r"[^\w\s-]", "", heading.strip().lower())
    return re.sub(r"\s+", "-", text)


def test_the_readme_is_a_front_page_whose_links_resolve():
    """At most 150 lines, opening with its commands (set up and run; set up and test; the
    full suite, which CI runs), and every relative link and picture pointing at a file of
    the repository, at a heading of it where the link names one."""
    text = README.read_text()
    lines = text.splitlines()
    assert len(lines) <= 150, f"README.md has {len(lines)} lines; the front page keeps 150"
    assert lines[2] == "```bash" and readme_commands()[:2] == [FIRST_COMMAND, TEST_COMMAND]
    targets = LINK.findall(text)
    assert targets, "the README links its documentation"
    for target in targets:
        if re.match(r"^[a-z][a-z0-9+.-]*:", target):
            continue
        path, _, anchor = target.partition("#")
        resolved = (ROOT / path) if path else README
        assert resolved.exists(), f"README.md links {target}, which is not in the repository"
        if anchor and resolved.suffix == ".md":
            headings = {slug(line.lstrip("#")) for line in resolved.read_text().splitlines()
                        if line.startswith("#")}
            assert anchor in headings, f"README.md links {target}: no such heading"


def test_the_readme_s_full_suite_installs_every_extra_as_ci_does():
    """The README's third command installs the extras `.ci/run` installs, and those are
    every extra of pyproject.toml (`paper` and `gymnasium` through `dev`): no backend's
    tests skip in the full suite."""
    full = readme_commands()[2]
    assert full.endswith(".venv/bin/python -m pytest -n auto --dist worksteal")
    ci, = EXTRAS.findall((ROOT / ".ci" / "run").read_text())
    assert EXTRAS.findall(full) == [ci]
    declared = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"][
        "optional-dependencies"]
    assert set(ci.split(",")) | {"paper", "gymnasium"} == set(declared)


def test_the_docs_write_in_what_comes_from_the_code():
    """The pages the hooks generate name every subcommand and every public name of `lwrl`,
    and a repository file linked from a report becomes its path."""
    import lwrl
    from lwrl.cli import main

    site = hooks()
    commands = [name for name, _, _ in site._subcommands(main.build_parser())]
    cli = site.cli_reference()
    assert {"train", "reproduce", "bench", "robustness", "device run"} <= set(commands)
    assert all(f"\n## lwrl {name}\n" in cli for name in commands)
    assert "`--alpha ALPHA`" in cli and "`--param NAME=VALUE`" in cli
    api = site.api_reference()
    assert all(f"::: {module}.{name}\n" in api for name, module in lwrl.PUBLIC.items())
    acrobot = ROOT / "docs" / "acrobot" / "README.md"
    shown = site.rewrite_links(acrobot.read_text(), acrobot.parent, acrobot.parent)
    assert "](../../tasks/acrobot.py)" in acrobot.read_text()
    assert "](../../tasks/acrobot.py)" not in shown and "`tasks/acrobot.py`" in shown


@pytest.mark.slow
def test_the_debugging_recipe_runs_the_loop_uncompiled_with_the_compiled_numbers(tmp_path):
    """The contributing page's block that runs the compiled loop as plain Python gives the
    compiled loop's numbers."""
    import lwrl

    page = (ROOT / "docs" / "contributing.md").read_text()
    section = page.split("### Running the loop uncompiled", 1)[1]
    recipe = section.split("```python\n", 1)[1].split("\n```", 1)[0]
    assert "kernels.Kernel.dispatcher = property(uncompiled)" in recipe
    out = tmp_path / "steps.npy"
    script = tmp_path / "recipe.py"
    script.write_text(recipe + f"\nnp.save({str(out)!r}, results.steps)\n")
    ran = subprocess.run([sys.executable, str(script)], capture_output=True, text=True,
                         timeout=600, cwd=tmp_path)
    assert ran.returncode == 0, ran.stderr[-3000:]
    call, = [node for node in ast.walk(ast.parse(recipe)) if isinstance(node, ast.Call)
             and getattr(node.func, "attr", None) == "RunConfig"]
    config = {keyword.arg: ast.literal_eval(keyword.value) for keyword in call.keywords}
    _, compiled = lwrl.run(lwrl.RunConfig(**config))
    np.testing.assert_array_equal(np.load(out), compiled.steps)


@pytest.fixture(scope="module")
def site(tmp_path_factory):
    """The site built by `mkdocs build --strict` into a temporary directory."""
    missing = [name for name in ("mkdocs", "material", "mkdocstrings", "mkdocstrings_handlers")
               if importlib.util.find_spec(name) is None]
    if missing:
        pytest.skip(f"the docs extra is not installed ({', '.join(missing)}): "
                    "pip install -e '.[docs]'")
    out = tmp_path_factory.mktemp("site")
    build = subprocess.run([sys.executable, "-m", "mkdocs", "build", "--strict", "--config-file",
                            str(ROOT / "mkdocs.yml"), "--site-dir", str(out)],
                           capture_output=True, text=True, timeout=900, cwd=ROOT,
                           env={**os.environ, "NO_MKDOCS_2_WARNING": "1"})
    assert build.returncode == 0, build.stderr[-5000:]
    assert not re.search(r"^WARNING\b", build.stderr, re.M), build.stderr[-5000:]
    return out


@pytest.mark.slow
def test_the_site_builds_strictly_with_the_api_and_the_generated_tables(site):
    """Every public name of `lwrl` has its entry in the API reference, the tasks page holds
    `lwrl tasks --parameters`'s tables, and the search index is written."""
    import lwrl
    from lwrl.cli.tasks import parameter_tables

    api = (site / "reference" / "api" / "lwrl" / "index.html").read_text()
    anchors = set(re.findall(r'id="([^"]+)"', api))
    assert {f"{module}.{name}" for name, module in lwrl.PUBLIC.items()} <= anchors
    tasks_page = html.unescape((site / "guide" / "tasks" / "index.html").read_text())
    for line in parameter_tables().splitlines():
        if line.startswith("| `"):
            name = line.split("`")[1]
            assert f"<code>{name}</code>" in tasks_page
    index = json.loads((site / "search" / "search_index.json").read_text())
    locations = {doc["location"] for doc in index["docs"]}
    assert {"guide/tasks/", "reference/cli/", "changelog/"} <= locations


@pytest.mark.slow
def test_the_404_page_links_to_the_site_s_own_files(site):
    """The 404 page, served at any address below the site, links from the site's root
    (`site_url`, by default `mkdocs serve`'s): every page, stylesheet and script it names is
    a file of the built site."""
    page = (site / "404.html").read_text()
    links = set(re.findall(r'(?:href|src)="([^"#]+)', page))
    local = {link for link in links if not re.match(r"^[a-z][a-z0-9+.-]*:", link)}
    assert local and all(link.startswith("/") for link in local), sorted(local)[:5]
    for link in local:
        target = site / link.lstrip("/")
        assert target.is_file() or (target / "index.html").is_file(), f"404.html links {link}"


def api_reference_entries() -> list[tuple[str, bool]]:
    """`(identifier, show_submodules)` of each `::: identifier` of the API reference's
    pages, the generated `lwrl` page's included."""
    pages = sorted((ROOT / "docs" / "reference" / "api").glob("*.md"))
    text = "\n".join(page.read_text() for page in pages) + "\n" + hooks().api_reference()
    return [(match[1], "show_submodules: true" in match[2])
            for match in re.finditer(r"^::: (\S+)\n((?:    .*\n)*)", text, re.M)]


@pytest.fixture(scope="module")
def griffe_lwrl():
    """lwrl's API as griffe reads it for mkdocstrings (mkdocs.yml: its inherited-docstrings
    extension); skips without the docs extra."""
    griffe = pytest.importorskip("griffe", reason="the docs extra is not installed: "
                                                  "pip install -e '.[docs]'")
    loader = griffe.GriffeLoader(search_paths=[str(ROOT)], extensions=griffe.load_extensions(
        "griffe_inherited_docstrings"))
    loader.load("lwrl")
    return loader.modules_collection


def shown(entry, submodules: bool):
    """`entry` and every object its API reference entry shows (mkdocs.yml's filters: no
    name starting with an underscore; imported names only where public; submodules where
    `submodules`)."""
    yield entry
    if entry.is_module or entry.is_class:
        for name, member in entry.members.items():
            if not (name.startswith("_") or (member.is_alias and not member.is_public)
                    or (member.is_module and not submodules)):
                yield from shown(member, submodules)


@pytest.mark.parametrize("identifier,submodules", api_reference_entries())
def test_every_name_of_the_api_reference_has_a_docstring(griffe_lwrl, identifier, submodules):
    """Each `::: identifier` of the API reference shows no name without a docstring."""
    bare = sorted({item.path for item in shown(griffe_lwrl[identifier], submodules)
                   if not (item.docstring and item.docstring.value.strip())})
    assert not bare, f"{len(bare)} names of {identifier}'s entry have no docstring: {bare}"


@pytest.fixture
def served(site):
    """The built site served on 127.0.0.1 by a local HTTP server: its root address."""
    class Quiet(http.server.SimpleHTTPRequestHandler):
        def log_message(self, *args):
            pass

    server = http.server.ThreadingHTTPServer(("127.0.0.1", 0),
                                             functools.partial(Quiet, directory=str(site)))
    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    yield f"http://127.0.0.1:{server.server_address[1]}/"
    server.shutdown()
    server.server_close()
    thread.join(timeout=10)


def evaluate(browser, session: str, expression: str):
    """The value of a JavaScript expression in the page."""
    reply = browser.call("Runtime.evaluate", {"expression": expression, "returnByValue": True},
                         session)
    return reply.get("result", {}).get("value")


def wait_for(browser, session: str, expression: str):
    """The expression's first truthy value within `WAIT` seconds, else None."""
    deadline = time.monotonic() + WAIT
    while time.monotonic() < deadline:
        value = evaluate(browser, session, expression)
        if value:
            return value
        time.sleep(0.2)
    return None


@pytest.mark.slow
def test_a_page_and_its_search_render_in_chromium(chromium, served):  # noqa: F811
    """In headless Chromium, the tasks page shows its title and the parameter tables, and a
    query typed into the search box lists the pages that hold it: the tasks page for a word
    only it has."""
    session = chromium.open(served + "guide/tasks/")
    title = wait_for(chromium, session, "document.readyState === 'complete' && "
                                        "document.querySelector('article h1')?.textContent")
    assert title and title.strip().rstrip("¶") == "The tasks"
    assert wait_for(chromium, session, "Array.from(document.querySelectorAll('article table "
                                       "code')).some(c => c.textContent === 'pole_mass')")
    evaluate(chromium, session, """(() => {
        const box = document.querySelector('[data-md-component=search-query]');
        box.focus();
        box.value = 'frictionloss';
        box.dispatchEvent(new Event('input', {bubbles: true}));
        box.dispatchEvent(new KeyboardEvent('keyup', {bubbles: true, key: 'i'}));
    })()""")
    found = wait_for(chromium, session, "(() => { const links = Array.from(document."
                                        "querySelectorAll('.md-search-result__item a'));"
                                        " return links.length && links.map(a => a.href); })()")
    assert found, "the search listed nothing for 'frictionloss'"
    assert any("/guide/tasks/" in link for link in found), found
    meta = evaluate(chromium, session, "document.querySelector('.md-search-result__meta')"
                                       ".textContent")
    assert "matching document" in meta
