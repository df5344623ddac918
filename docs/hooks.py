"""MkDocs hooks of lwrl's documentation site (`mkdocs.yml`): the pages that come from the
code, and the links that leave `docs/`.

Pages written at build time, from the code and the repository's own files, so that they
cannot drift from what they describe:

- `index.md`, the front page: the repository's README.md;
- `changelog.md`: the repository's CHANGELOG.md;
- `reference/api/lwrl.md`: every public name of `lwrl` (`lwrl.PUBLIC`, what `help(lwrl)`
  lists), each from the docstrings of the module it lives in;
- `reference/cli.md`: every `lwrl` subcommand with its usage and flags, read from the
  command's own argparse parsers (`lwrl.cli.main.build_parser`), as `lwrl COMMAND --help`
  prints them.

A page's line `<!-- lwrl: parameter-tables -->` becomes each domain's physical parameters
as `lwrl tasks --parameters` prints them (`lwrl.cli.tasks.parameter_tables`, from the
domains' declarations).

A link from a page to a file of the repository outside `docs/` (a report's
`../../tasks/acrobot.py`) works on the repository's own pages but leads nowhere on the site:
it becomes the file's path, as code. A link whose file does not exist is left as it is, so
that the strict build fails on it. Links of the pages taken from the repository's root
(README.md, CHANGELOG.md) into `docs/` are rewritten to the site's pages.

Nothing here imports MkDocs at module level: the tests call `generate`, `cli_reference` and
`api_reference` without it.
"""

import argparse
import contextlib
import os
import pathlib
import re

DOCS = pathlib.Path(__file__).resolve().parent
"""The site's sources (`docs_dir`)."""
ROOT = DOCS.parent
"""The repository."""

PARAMETER_TABLES = "<!-- lwrl: parameter-tables -->"
"""The line that `generate` replaces with `lwrl tasks --parameters`'s tables."""

FROM_ROOT = {"index.md": "README.md", "changelog.md": "CHANGELOG.md"}
"""`{page: the repository's file it is}`."""
PAGES_OF_ROOT = {source: page for page, source in FROM_ROOT.items()}
"""`{the repository's file: its page}`."""

_LINK = re.compile(r"(!?)\[((?:[^\[\]]|\[[^\]]*\])*)\]\(([^()\s]+)\)")
_FENCE = re.compile(r"^\s*(```|~~~)")


def generate(markdown: str) -> str:
    """`markdown` with its generated parts written in (`PARAMETER_TABLES`)."""
    if PARAMETER_TABLES in markdown:
        from lwrl.cli.tasks import parameter_tables

        markdown = markdown.replace(PARAMETER_TABLES, parameter_tables())
    return markdown


def _target(link: str, source: pathlib.Path, page: pathlib.Path) -> str | None:
    """What `link`, written in a file of the folder `source`, becomes on the site page of
    the folder `page` (both absolute): None to keep it, else a new target, or `` `path` ``
    for a repository file outside `docs/`."""
    if re.match(r"^[a-z][a-z0-9+.-]*:", link) or link.startswith(("#", "/")):
        return None
    path, hash_, anchor = link.partition("#")
    if not path:
        return None
    resolved = pathlib.Path(os.path.normpath(source / path))
    if not resolved.exists():
        return None  # the strict build names it
    if resolved == DOCS or DOCS in resolved.parents:
        if source == page:
            return None
        return os.path.relpath(resolved, page) + hash_ + anchor
    if resolved.parent == ROOT and resolved.name in PAGES_OF_ROOT:
        return os.path.relpath(DOCS / PAGES_OF_ROOT[resolved.name], page) + hash_ + anchor
    if resolved == ROOT or ROOT in resolved.parents:
        path = resolved.relative_to(ROOT).as_posix() + ("/" if resolved.is_dir() else "")
        return f"`{path}`"
    return None


def rewrite_links(markdown: str, source: pathlib.Path, page: pathlib.Path) -> str:
    """The links of `markdown` (a file of the folder `source`, shown as a page of the folder
    `page`) as the site needs them (see the module's docstring); code blocks untouched."""
    out, prose, fenced = [], [], None

    def flush():
        if not prose:
            return
        text = "\n".join(prose)
        out.append(_LINK.sub(lambda match: _rewrite(match, source, page), text) if "](" in text
                   else text)
        prose.clear()

    for line in markdown.split("\n"):
        fence = _FENCE.match(line)
        if fenced is None and fence:
            flush()
            fenced = fence.group(1)
            out.append(line)
        elif fenced is not None:
            if fence and fence.group(1) == fenced:
                fenced = None
            out.append(line)
        else:
            prose.append(line)
    flush()
    return "\n".join(out)


def _rewrite(match, source: pathlib.Path, page: pathlib.Path) -> str:
    image, text, link = match.groups()
    target = _target(link, source, page)
    if target is None:
        return match.group(0)
    if not target.startswith("`"):
        return f"{image}[{text}]({target})"
    if image:
        return match.group(0)  # an image outside docs/: the strict build names it
    path = target.strip("`")
    if text.strip("`") == path.rstrip("/"):
        return target
    return text if path.rstrip("/") in text else f"{text} ({target})"


@contextlib.contextmanager
def _columns(width: int):
    """argparse's width while the reference is written (it reads `$COLUMNS`)."""
    before = os.environ.get("COLUMNS")
    os.environ["COLUMNS"] = str(width)
    try:
        yield
    finally:
        if before is None:
            del os.environ["COLUMNS"]
        else:
            os.environ["COLUMNS"] = before


def _cell(text: str) -> str:
    return " ".join(text.split()).replace("|", "\\|")


def _subcommands(parser: argparse.ArgumentParser):
    """`(name, parser, help)` of each subcommand of `parser`, in order, nested ones after
    their command."""
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            helps = {choice.dest: choice.help for choice in action._choices_actions}
            for name, sub in action.choices.items():
                yield name, sub, helps.get(name, "")
                for nested, subsub, subhelp in _subcommands(sub):
                    yield f"{name} {nested}", subsub, subhelp


def _flags(parser: argparse.ArgumentParser) -> list:
    """The Markdown lines of `parser`'s arguments, one table per argument group."""
    formatter = parser._get_formatter()
    lines = []
    for group in parser._action_groups:
        actions = [action for action in group._group_actions
                   if action.help != argparse.SUPPRESS
                   and not isinstance(action, (argparse._HelpAction, argparse._SubParsersAction))]
        if not actions:
            continue
        lines += ["", f"**{group.title}**", "", "| argument | what it is |", "|---|---|"]
        for action in actions:
            name = formatter._format_action_invocation(action)
            text = formatter._expand_help(action) if action.help else ""
            if action.choices is not None and not isinstance(action.choices, dict):
                if "{" not in name:
                    text += f" (one of: {', '.join(map(str, action.choices))})"
            lines.append(f"| `{_cell(name)}` | {_cell(text)} |")
    return lines


def cli_reference() -> str:
    """The page of every `lwrl` subcommand: what it does, its usage and its flags, from the
    parsers `lwrl` itself builds."""
    from lwrl.cli import main

    with _columns(100):
        parser = main.build_parser()
        lines = ["# The `lwrl` command", "",
                 "Generated from the command's own parsers (`lwrl.cli.main.build_parser`) when "
                 "the site is built: each section is what `lwrl COMMAND --help` prints, as "
                 "tables. Bad input ends with one line on standard error and exit status 2.",
                 "", "```text", parser.format_usage().rstrip(), "```"]
        for name, sub, help_text in _subcommands(parser):
            lines += ["", f"## lwrl {name}", ""]
            if sub.description or help_text:
                lines += [_cell(sub.description or help_text), ""]
            lines += ["```text", sub.format_usage().rstrip(), "```"]
            lines += _flags(sub)
    return "\n".join(lines) + "\n"


def api_reference() -> str:
    """The page of `lwrl` itself: its docstring, then each public name (`lwrl.PUBLIC`) from
    the module it lives in."""
    import lwrl

    lines = ["# `lwrl`", "",
             "What `import lwrl` gives: the names `help(lwrl)` lists, each documented where it "
             "lives (its module's path is its full name). Generated from `lwrl.PUBLIC` when the "
             "site is built, so a public name added there appears here.", "",
             "::: lwrl", "    options:", "      members: false", "      show_root_heading: false"]
    for name, module in lwrl.PUBLIC.items():
        lines += ["", f"::: {module}.{name}", "    options:", "      heading_level: 2",
                  "      show_root_full_path: false"]
    return "\n".join(lines) + "\n"


GENERATED = {"reference/api/lwrl.md": api_reference, "reference/cli.md": cli_reference}
"""`{page: the function that writes it}`."""


def on_files(files, config):
    """Add the generated pages and the pages taken from the repository's root."""
    from mkdocs.structure.files import File

    for page, source in FROM_ROOT.items():
        files.append(File.generated(config, page, content=(ROOT / source).read_text()))
    for page, write in GENERATED.items():
        files.append(File.generated(config, page, content=write()))
    return files


def on_page_markdown(markdown, page, config, files):
    """Write in the generated parts, and make the links the site's."""
    src = page.file.src_uri
    where = DOCS / pathlib.PurePosixPath(src).parent
    source = ROOT if src in FROM_ROOT else where
    return rewrite_links(generate(markdown), source, where)
