#!/usr/bin/python3
# SPDX-License-Identifier: GPL-3.0-or-later
"""Option tables of the `rbc` sub-commands, read from the executable's own --help.

As a Sphinx extension (listed in conf.py) it adds two directives, so the user guide's tables
are regenerated from the built executable on every documentation build and never drift:

    ```{rbc-options} stretch
    ```          -> the table of `rbc stretch --help`: option, value, default, description
    ```{rbc-commands}
    ```          -> the table of sub-commands from `rbc --help`

The executable is conf.py's `rbc_executable` (RBC_BUILD_DIR/rbc). A missing executable or an
unparsable help text is a build error.

As a script it prints the same tables as Markdown:
    /usr/bin/python3 docs/gen_cli.py [--rbc build/rbc] [COMMAND ...]
"""
from __future__ import annotations

import argparse
import functools
import re
import subprocess
import sys
from dataclasses import dataclass

HELP_COLUMN = 30  # CLI11 writes descriptions from this column


@dataclass
class Option:
    names: str  # "-n,--vertices"
    value: str  # "INT in [100, 40000]", "one of: a, b", "" for a flag
    default: str
    repeatable: bool
    description: str


@functools.lru_cache(maxsize=None)
def help_text(rbc: str, command: str | None) -> str:
    args = [rbc] + ([command] if command else []) + ["--help"]
    p = subprocess.run(args, capture_output=True, text=True, check=False)
    if p.returncode != 0 or not p.stdout.strip():
        raise RuntimeError(f"'{' '.join(args)}' failed (exit {p.returncode}): {p.stderr.strip()}")
    return p.stdout


def _value(spec: str) -> tuple[str, str, bool]:
    """Splits CLI11's type column ("INT:INT in [1, 9]=2 ...") into value, default, repeatable.
    An option without a default that must be given ("TEXT REQUIRED") has the default
    "(required)"."""
    required = spec.endswith(" REQUIRED")
    if required:
        spec = spec[: -len(" REQUIRED")]
    repeatable = spec.endswith(" ...")
    if repeatable:
        spec = spec[: -len(" ...")]
    m = re.fullmatch(r"(?P<type>[A-Z0-9]+)(?::(?P<check>.*?))?(?:=(?P<default>.*))?", spec)
    if not m:
        raise RuntimeError(f"cannot parse the option value '{spec}'")
    check = m.group("check") or ""
    if check.startswith("{") and check.endswith("}"):
        value = "one of: " + ", ".join(check[1:-1].split(","))
    elif check:
        value = re.sub(r"^(INT|UINT|FLOAT)(64)?\b", "", check).strip()
        value = f"{m.group('type')} {value}".strip() if value else m.group("type")
    else:
        value = m.group("type")
    return value, m.group("default") or ("(required)" if required else ""), repeatable


def parse_options(text: str) -> list[Option]:
    """The options of one CLI11 help text, in order (without -h,--help): the command's own,
    then those of its option groups ("[Option Group: Model]", indented two more columns)."""
    lines = text.splitlines()
    try:
        start = lines.index("Options:") + 1
    except ValueError as e:
        raise RuntimeError("no 'Options:' section in the help text") from e
    out = _parse_block(lines[start:])
    for k, line in enumerate(lines):
        if line.startswith("[Option Group:"):
            j = k + 1
            while j < len(lines) and lines[j].strip() != "Options:":
                j += 1
            out += _parse_block([l[2:] for l in lines[j + 1:]])
    return out


def _parse_block(lines: list[str]) -> list[Option]:
    """Option lines up to the first blank or unindented line."""
    out: list[Option] = []
    i = 0
    while i < len(lines) and lines[i].strip() and lines[i].startswith(" "):
        line = lines[i]
        if not line.startswith("  -"):
            raise RuntimeError(f"unexpected help line '{line}'")
        nxt = lines[i + 1] if i + 1 < len(lines) else ""
        if nxt.startswith(" " * HELP_COLUMN) and nxt.strip():
            spec, desc = line.strip(), nxt.strip()
            i += 2
        else:
            spec, desc = line[:HELP_COLUMN].strip(), line[HELP_COLUMN:].strip()
            i += 1
        names, _, rest = spec.partition(" ")
        if names == "-h,--help":
            continue
        value, default, repeatable = _value(rest.strip()) if rest.strip() else ("", "", False)
        out.append(Option(names, value, default, repeatable, desc))
    return out


def parse_commands(text: str) -> list[tuple[str, str]]:
    """(name, summary) of every sub-command in `rbc --help`."""
    lines = text.splitlines()
    start = lines.index("Subcommands:") + 1
    out = []
    for line in lines[start:]:
        if not line.strip():
            break
        out.append((line[:HELP_COLUMN].strip(), line[HELP_COLUMN:].strip()))
    return out


def summary(text: str) -> str:
    return text.splitlines()[0].strip()


def markdown_table(options: list[Option]) -> str:
    rows = ["| option | value | default | description |", "|---|---|---|---|"]
    for o in options:
        esc = lambda s: s.replace("|", "\\|")  # noqa: E731
        value = o.value or "(flag)"
        if o.repeatable:
            value += " (repeatable)"
        rows.append(f"| `{o.names}` | {esc(value)} | {('`' + o.default + '`') if o.default else ''}"
                    f" | {esc(o.description)} |")
    return "\n".join(rows)


# ----------------------------------------------------------------------------- Sphinx extension
def setup(app):
    from docutils import nodes
    from docutils.parsers.rst import Directive

    def table(headers: list[str], widths: list[int], rows: list[list[nodes.Node]]) -> nodes.table:
        t = nodes.table(classes=["rbc-options"])
        group = nodes.tgroup(cols=len(headers))
        t += group
        for w in widths:
            group += nodes.colspec(colwidth=w)
        head = nodes.thead()
        group += head
        hrow = nodes.row()
        for h in headers:
            hrow += nodes.entry("", nodes.paragraph(text=h))
        head += hrow
        body = nodes.tbody()
        group += body
        for cells in rows:
            r = nodes.row()
            for c in cells:
                r += nodes.entry("", c)
            body += r
        return t

    def para(*children: nodes.Node) -> nodes.paragraph:
        p = nodes.paragraph()
        for c in children:
            p += c
        return p

    def rbc_path(directive) -> str:
        return directive.state.document.settings.env.config.rbc_executable

    class OptionsDirective(Directive):
        required_arguments = 1
        has_content = False

        def run(self):
            command = self.arguments[0]
            try:
                opts = parse_options(help_text(rbc_path(self), command))
            except (RuntimeError, OSError) as e:
                raise self.error(f"rbc-options {command}: {e}")
            if not opts:
                return [para(nodes.Text("No options besides "), nodes.literal(text="-h,--help"),
                             nodes.Text("."))]
            rows = []
            for o in opts:
                value = o.value or "flag"
                if o.repeatable:
                    value += ", repeatable"
                cell = para(nodes.Text(value))
                if o.default:
                    cell += nodes.Text("; default ")  # long ones wrap (_static/rbc.css)
                    cell += nodes.literal(text=o.default)
                rows.append([
                    para(nodes.literal(text=o.names.replace(",", ", "))),
                    cell,
                    para(nodes.Text(o.description)),
                ])
            return [table(["option", "value and default", "description"], [22, 28, 50], rows)]

    class CommandsDirective(Directive):
        has_content = False

        def run(self):
            try:
                cmds = parse_commands(help_text(rbc_path(self), None))
            except (RuntimeError, OSError, ValueError) as e:
                raise self.error(f"rbc-commands: {e}")
            env = self.state.document.settings.env
            rows = []
            for name, text in cmds:
                ref = nodes.reference("", "", internal=True,
                                      refuri=env.app.builder.get_relative_uri(
                                          env.docname, f"guide/{name}"))
                ref += nodes.literal(text=f"rbc {name}")
                rows.append([para(ref), para(nodes.Text(text))])
            return [table(["command", "what it does"], [20, 80], rows)]

    app.add_config_value("rbc_executable", "rbc", "env")
    app.add_directive("rbc-options", OptionsDirective)
    app.add_directive("rbc-commands", CommandsDirective)
    return {"version": "1", "parallel_read_safe": True, "parallel_write_safe": True}


def main() -> int:
    ap = argparse.ArgumentParser(description="Print the rbc option tables as Markdown.")
    ap.add_argument("--rbc", default="build/rbc")
    ap.add_argument("commands", nargs="*")
    a = ap.parse_args()
    commands = a.commands or [n for n, _ in parse_commands(help_text(a.rbc, None))]
    for c in commands:
        text = help_text(a.rbc, c)
        print(f"## rbc {c}\n\n{summary(text)}\n\n{markdown_table(parse_options(text))}\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
