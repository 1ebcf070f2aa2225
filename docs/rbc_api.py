# SPDX-License-Identifier: GPL-3.0-or-later
"""Sphinx extension: one C++ header's API, in the header's own order, through Breathe.

    ```{rbc-header} discrete/stretch.hpp
    ```

Doxygen's XML lists namespace members under the namespace, not under the file, so Breathe's
`doxygenfile` cannot show "what this header declares". This directive reads the XML (conf.py's
breathe project "rbc"), takes the documented classes, functions, enums, typedefs and variables
whose declaration lies in the header, sorts them by line and emits one Breathe directive each
(`doxygenstruct`, `doxygenfunction` with its argument list for overloads, ...), written in
MyST syntax because the pages are MyST Markdown.
"""
from __future__ import annotations

import functools
import pathlib
import re
import xml.etree.ElementTree as ET

from docutils import nodes
from docutils.parsers.rst import Directive
from docutils.statemachine import StringList
from sphinx.util.nodes import nested_parse_with_titles


def _args(argsstring: str) -> str:
    """'(const A &a, int n=2) const' -> '(const A &a, int n)': Breathe matches without defaults."""
    depth, out, i = 0, [], 0
    s = argsstring.strip()
    end = 0
    for i, ch in enumerate(s):
        depth += ch == "("
        depth -= ch == ")"
        if depth == 0 and ch == ")":
            end = i + 1
            break
    inner = s[1:end - 1]
    params, depth, cur = [], 0, ""
    for ch in inner:
        if ch in "<([{":
            depth += 1
        elif ch in ">)]}":
            depth -= 1
        if ch == "," and depth == 0:
            params.append(cur)
            cur = ""
        else:
            cur += ch
    if cur.strip():
        params.append(cur)
    cleaned = []
    for p in params:
        depth, cut = 0, len(p)
        for j, ch in enumerate(p):
            if ch in "<([{":
                depth += 1
            elif ch in ">)]}":
                depth -= 1
            elif ch == "=" and depth == 0:
                cut = j
                break
        cleaned.append(p[:cut].strip())
    out = "(" + ", ".join(cleaned) + ")"
    tail = s[end:].strip()
    if re.match(r"^const\b", tail):
        out += " const"
    return out


@functools.lru_cache(maxsize=None)
def _all_entries(xml_dir: pathlib.Path) -> dict[str, list[tuple[int, str]]]:
    """Every documented entity of the XML, grouped by the header that declares it (parsed once)."""
    by_header: dict[str, list[tuple[int, str]]] = {}
    index = ET.parse(xml_dir / "index.xml").getroot()
    overloads: dict[str, int] = {}
    members = []
    namespaces = {c.findtext("name") for c in index.findall("compound") if c.get("kind") == "namespace"}
    for comp in index.findall("compound"):
        kind = comp.get("kind")
        if kind in ("struct", "class"):
            root = ET.parse(xml_dir / f"{comp.get('refid')}.xml").getroot().find("compounddef")
            loc = root.find("location")
            name = root.find("compoundname").text
            if loc is None or name.rpartition("::")[0] not in namespaces:
                continue  # nested types are shown by their enclosing class
            by_header.setdefault(loc.get("file"), []).append(
                (int(loc.get("line", 0)), f"```{{doxygen{kind}}} {name}\n:members:\n:undoc-members:\n```\n"))
        elif kind == "namespace":
            root = ET.parse(xml_dir / f"{comp.get('refid')}.xml").getroot().find("compounddef")
            ns = root.find("compoundname").text
            for m in root.iter("memberdef"):
                if m.get("kind") == "function":  # overloads anywhere in the namespace
                    key = ns + "::" + m.find("name").text
                    overloads[key] = overloads.get(key, 0) + 1
                loc = m.find("location")
                if loc is None:
                    continue
                decl = loc.get("declfile", loc.get("file"))
                members.append((decl, ns, m, int(loc.get("declline", loc.get("line", 0)))))
    for decl, ns, m, line in members:
        name = f"{ns}::{m.find('name').text}"
        kind = m.get("kind")
        if kind == "function":
            sig = _args(m.find("argsstring").text or "()") if overloads[name] > 1 else ""
            text = f"```{{doxygenfunction}} {name}{sig}\n```\n"
        elif kind in ("enum", "typedef", "variable"):
            text = f"```{{doxygen{kind}}} {name}\n```\n"
        else:
            continue
        by_header.setdefault(decl, []).append((line, text))
    return {h: sorted(e) for h, e in by_header.items()}


def header_entries(xml_dir: pathlib.Path, header: str) -> list[tuple[int, str]]:
    """(line, MyST directive) of every entity declared in `header`, in line order."""
    return _all_entries(xml_dir).get(header, [])


def folder_headers(root: pathlib.Path, folder: str) -> list[str]:
    return sorted(str(p.relative_to(root)) for p in (root / folder).glob("*.hpp"))


def _parse_myst(directive, text: str, source: str) -> list[nodes.Node]:
    rst = StringList()
    for line in text.splitlines():
        rst.append(line, source)
    node = nodes.container()
    nested_parse_with_titles(directive.state, rst, node)
    return node.children


class FolderDirective(Directive):
    """Every header of one source folder, each under its own heading (H2)."""

    required_arguments = 1
    has_content = False

    def run(self):
        env = self.state.document.settings.env
        xml_dir = pathlib.Path(env.config.breathe_projects["rbc"])
        root = pathlib.Path(env.config.rbc_source_root)
        folder = self.arguments[0]
        text = []
        for header in folder_headers(root, folder):
            entries = header_entries(xml_dir, header)
            text.append(f"## `{header}`\n")
            if not entries:
                text.append("(nothing documented)\n")
            text.extend(t for _, t in entries)
        return _parse_myst(self, "\n".join(text), f"<rbc-folder {folder}>")


class HeaderDirective(Directive):
    required_arguments = 1
    has_content = False

    def run(self):
        env = self.state.document.settings.env
        xml_dir = pathlib.Path(env.config.breathe_projects["rbc"])
        header = self.arguments[0]
        try:
            entries = header_entries(xml_dir, header)
        except (OSError, ET.ParseError) as e:
            raise self.error(f"rbc-header {header}: {e}")
        if not entries:
            raise self.error(f"rbc-header {header}: no documented entity found")
        rst = StringList()
        for _, text in entries:
            for line in text.splitlines():
                rst.append(line, f"<rbc-header {header}>")
            rst.append("", f"<rbc-header {header}>")
        node = nodes.container()
        nested_parse_with_titles(self.state, rst, node)
        return node.children


def setup(app):
    app.add_config_value("rbc_source_root", ".", "env")
    app.add_directive("rbc-header", HeaderDirective)
    app.add_directive("rbc-folder", FolderDirective)
    return {"version": "1", "parallel_read_safe": True, "parallel_write_safe": True}
