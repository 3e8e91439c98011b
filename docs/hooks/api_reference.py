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

_pages: dict[str, str] = {}


def _exports(path: Path) -> list[str] | None:
    """The literal ``__all__`` of a source file, or None when it declares none."""
    tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
    for node in tree.body:
        if isinstance(node, ast.Assign) and any(isinstance(t, ast.Name) and t.id == "__all__" for t in node.targets):
            return [str(v) for v in ast.literal_eval(node.value)]
    return None


def public_modules(root: Path) -> dict[str, list[str]]:
    """Dotted module name -> its ``__all__``, for every public module under ``root/morphkit``."""
    modules: dict[str, list[str]] = {}
    for path in sorted((root / PACKAGE).rglob("*.py")):
        parts = list(path.relative_to(root).with_suffix("").parts)
        if parts[-1] == "__init__":
            parts.pop()
        name = ".".join(parts)
        if any(p.startswith("_") for p in parts) or name.startswith(EXCLUDED):
            continue
        names = _exports(path)
        if names:
            modules[name] = names
    return modules


def api_pages(root: Path) -> dict[str, str]:
    """Page path (relative to docs/) -> markdown, one page per public module with names of its own."""
    modules = public_modules(root)
    pages: dict[str, str] = {}
    for name, exports in modules.items():
        parts = name.split(".")
        ancestors = [".".join(parts[:i]) for i in range(2, len(parts))]  # not the top-level package
        higher = {n for a in ancestors for n in modules.get(a, [])}
        own = [n for n in exports if n not in higher and not n.startswith("__")]
        if name == PACKAGE:
            pages[f"{API_DIR}/{name}.md"] = _top_page(own)
        elif own:
            pages[f"{API_DIR}/{name}.md"] = _module_page(name, own)
    return pages


def _module_page(name: str, members: list[str]) -> str:
    listed = ", ".join(f'"{m}"' for m in members)
    return (
        f"# `{name}`\n\n"
        f"::: {name}\n"
        "    options:\n"
        "      show_root_heading: false\n"
        "      show_root_toc_entry: false\n"
        "      members_order: alphabetical\n"
        f"      members: [{listed}]\n"
    )


def _top_page(members: list[str]) -> str:
    links = "\n".join(f"- [`morphkit.{m}`][morphkit.{m}]" for m in members)
    head = "# `morphkit`\n\n::: morphkit\n    options:\n      show_root_heading: false\n      members: false\n"
    return f"{head}\n{links}\n"


def on_config(config):
    """Generate the pages and add an "API reference" section to the nav (before the changelog)."""
    root = Path(config["config_file_path"]).resolve().parent
    _pages.clear()
    _pages.update(api_pages(root))
    section = {"API reference": [{Path(p).stem: p} for p in sorted(_pages)]}
    nav = config["nav"]
    if nav is not None:
        at = next((i for i, item in enumerate(nav) if isinstance(item, dict) and "Changelog" in item), len(nav))
        nav.insert(at, section)
    return config


def on_files(files, config):
    """Add the generated pages as in-memory files."""
    for path, text in _pages.items():
        files.append(File.generated(config, path, content=text))
    return files


def on_page_content(html, page, config, files):
    """Register the unit anchors on the conventions page."""
    if page.file.src_uri == UNITS_PAGE:
        autorefs = config["plugins"]["autorefs"]
        for unit in UNITS:
            autorefs.register_anchor(page, unit, UNITS_ANCHOR, primary=True)
    return html
