"""mkdocs hook: the API reference, one page per public morphkit module, generated from its ``__all__``.

A module is public when no part of its dotted name starts with an underscore and it declares
``__all__``. A name is documented once, on the page of the highest package that exports it
(``morphkit.torch.fk`` rather than ``morphkit.torch.functions.fk``); the top-level ``morphkit``
package only re-exports conveniences, so it links to them instead. Nothing is imported: ``__all__``
is read from the source, and mkdocstrings (griffe) reads the code statically, so the docs build
needs neither Warp nor torch. A new public name appears in the reference without editing the docs.
"""

from __future__ import annotations

import ast
import logging
import re
from pathlib import Path

from mkdocs.structure.files import File

log = logging.getLogger("mkdocs.hooks.api_reference")

PACKAGE = "morphkit"
API_DIR = "api"
# The CLI's subcommand modules are reached through `morphkit COMMAND` (see the guides), not imported.
EXCLUDED = ("morphkit.cli", "morphkit.commands")

# Docstrings give units in brackets (`[..., 3] [m]`), which Markdown reads as reference links: they
# resolve to the units section of the conventions page instead of failing the strict build.
UNITS = ("m", "rad", "s", "m/s", "rad/s", "m/s^2", "deg", "Hz")
UNITS_PAGE = "concepts/conventions.md"
UNITS_ANCHOR = "units-in-the-api-reference"

# Docstrings use Sphinx roles (:func:`~morphkit.x.f`), which Markdown leaves as text before a code span; on the
# API pages they become cross-references (autorefs resolves them, silently leaving unknown names as code).
SPHINX_ROLE = re.compile(r":(?:class|func|meth|mod|data|attr|exc|obj):<code>(~?)([\w.]+)</code>")

_pages: dict[str, str] = {}


def _exports(path: Path) -> list[str] | None:
    """The literal ``__all__`` of a source file, or None when it declares none."""
    tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
    for node in tree.body:
        if isinstance(node, ast.Assign) and any(isinstance(t, ast.Name) and t.id == "__all__" for t in node.targets):
            return [str(v) for v in ast.literal_eval(node.value)]
    return None


def _bindings(path: Path) -> tuple[set[str], dict[str, str]]:
    """Names a module binds so that griffe sees them (defs, classes, ``x = ...``, imports), and names bound
    together by tuple unpacking (``A, B = range(2)``: griffe does not see them) -> the statement's source."""
    tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
    plain: set[str] = set()
    tuples: dict[str, str] = {}
    for node in tree.body:
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
            plain.add(node.name)
        elif isinstance(node, (ast.Import, ast.ImportFrom)):
            plain.update((a.asname or a.name).split(".")[0] for a in node.names)
        elif isinstance(node, ast.AnnAssign) and isinstance(node.target, ast.Name):
            plain.add(node.target.id)
        elif isinstance(node, ast.Assign):
            for t in node.targets:
                if isinstance(t, ast.Name):
                    plain.add(t.id)
                elif isinstance(t, ast.Tuple):
                    tuples.update({e.id: ast.unparse(node) for e in t.elts if isinstance(e, ast.Name)})
    return plain, tuples


class _Module:
    def __init__(self, name: str, path: Path, exports: list[str]) -> None:
        self.name, self.path, self.exports = name, path, exports
        self.is_package = path.name == "__init__.py"
        self.plain, self.tuples = _bindings(path)
        submodules = {p.stem for p in path.parent.glob("*.py")} | {p.name for p in path.parent.iterdir() if p.is_dir()}
        # What griffe renders under this module's name: bound here, and not hidden by a submodule of the same
        # name (`morphkit.motion.features` is the submodule to griffe, the function at run time). Names exported
        # lazily (module __getattr__) or so hidden are documented in the module that defines them.
        self.visible = [n for n in exports if n in self.plain and not (self.is_package and n in submodules)]


def public_modules(root: Path) -> dict[str, _Module]:
    """Dotted module name -> its source and ``__all__``, for every public module under ``root/morphkit``."""
    modules: dict[str, _Module] = {}
    for path in sorted((root / PACKAGE).rglob("*.py")):
        parts = list(path.relative_to(root).with_suffix("").parts)
        if parts[-1] == "__init__":
            parts.pop()
        name = ".".join(parts)
        if any(p.startswith("_") for p in parts) or name.startswith(EXCLUDED):
            continue
        names = _exports(path)
        if names:
            modules[name] = _Module(name, path, names)
    return modules


def api_pages(root: Path) -> dict[str, str]:
    """Page path (relative to docs/) -> markdown, one page per public module with names of its own."""
    modules = public_modules(root)
    pages: dict[str, str] = {}
    for name, mod in modules.items():
        parts = name.split(".")
        ancestors = [".".join(parts[:i]) for i in range(2, len(parts))]  # not the top-level package
        higher = {n for a in ancestors if a in modules for n in modules[a].visible}
        own = [n for n in mod.exports if n not in higher and not n.startswith("__")]
        if name == PACKAGE:
            pages[f"{API_DIR}/{name}.md"] = _top_page(own)
            continue
        rendered = [n for n in own if n in mod.visible or (not mod.is_package and n not in mod.tuples)]
        elsewhere = {n: _definer(modules, name, n) for n in own if mod.is_package and n not in mod.visible}
        tupled = {n: mod.tuples[n] for n in own if n in mod.tuples and n not in mod.plain}
        if rendered or tupled or elsewhere:
            pages[f"{API_DIR}/{name}.md"] = _module_page(name, rendered, tupled, elsewhere)
    return pages


def _definer(modules: dict[str, _Module], package: str, name: str) -> str | None:
    """The submodule of ``package`` whose ``__all__`` holds ``name`` (where its documentation is)."""
    return next((m for m, mod in modules.items() if m.startswith(package + ".") and name in mod.exports), None)


def _module_page(name: str, members: list[str], tupled: dict[str, str], elsewhere: dict[str, str | None]) -> str:
    listed = ", ".join(f'"{m}"' for m in members)
    text = (
        f"# `{name}`\n\n"
        f"::: {name}\n"
        "    options:\n"
        "      show_root_heading: false\n"
        "      show_root_toc_entry: false\n"
        "      members_order: alphabetical\n"
        f"      members: [{listed}]\n"
    )
    for stmt in dict.fromkeys(tupled.values()):  # one section per statement, one heading per name
        text += f"\n## Bound together\n\n```python\n{stmt}\n```\n\n"
        text += "".join(f"### `{n}` {{#{name}.{n}}}\n\n" for n, s in tupled.items() if s == stmt)
    if elsewhere:
        text += "\n## Also exported here\n\nDocumented in the module that defines them:\n\n"
        text += "\n".join(f"- [`{n}`][{d}.{n}]" if d else f"- `{n}`" for n, d in elsewhere.items()) + "\n"
    return text


def _top_page(members: list[str]) -> str:
    links = "\n".join(f"- [`morphkit.{m}`][morphkit.{m}]" for m in members)
    head = "# `morphkit`\n\n::: morphkit\n    options:\n      show_root_heading: false\n      members: false\n"
    return f"{head}\n{links}\n"


def on_config(config):
    """Generate the pages and add an "API reference" section to the nav (before the changelog)."""
    root = Path(config["config_file_path"]).resolve().parent
    _pages.clear()
    _pages.update(api_pages(root))
    section = {"API reference": _api_nav(_pages)}
    nav = config["nav"]
    if nav is not None:
        at = next((i for i, item in enumerate(nav) if isinstance(item, dict) and "Changelog" in item), len(nav))
        nav.insert(at, section)
    return config


def _api_nav(pages: dict[str, str]) -> list:
    """Nav entries: one group per subpackage (the package's page first, then its modules), in name order."""
    groups: dict[str, list[dict[str, str]]] = {}
    for path in sorted(pages, key=lambda p: Path(p).stem.split(".")):
        name = Path(path).stem
        groups.setdefault(".".join(name.split(".")[:2]), []).append({name: path})
    return [entries[0] if len(entries) == 1 else {group: entries} for group, entries in groups.items()]


def on_files(files, config):
    """Add the generated pages as in-memory files."""
    for path, text in _pages.items():
        files.append(File.generated(config, path, content=text))
    return files


def _role(match: re.Match, module: str) -> str:
    short, name = match.group(1), match.group(2)
    identifier = name if name.startswith(f"{PACKAGE}.") else f"{module}.{name}"
    title = name.rsplit(".", 1)[-1] if short else name
    return f'<span data-autorefs-optional="{identifier}"><code>{title}</code></span>'


def on_page_content(html, page, config, files):
    """Sphinx roles on the API pages become cross-references; the unit anchors live on the conventions page."""
    if page.file.src_uri in _pages:
        module = page.file.src_uri.removeprefix(f"{API_DIR}/").removesuffix(".md")
        html = SPHINX_ROLE.sub(lambda m: _role(m, module), html)
    if page.file.src_uri == UNITS_PAGE:
        autorefs = config["plugins"]["autorefs"]
        for unit in UNITS:
            autorefs.register_anchor(page, unit, UNITS_ANCHOR, primary=True)
    return html
