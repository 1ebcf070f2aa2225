#!/usr/bin/python3
# SPDX-License-Identifier: GPL-3.0-or-later
"""Runs the shell and Python blocks of the documentation pages and checks their stated numbers.

Usage: /usr/bin/python3 docs/run_snippets.py [--build BUILD_DIR] [PAGE.md ...]
(default pages: docs/getting-started/first-run.md, docs/tutorials/*.md and
docs/validation/determinism.md; default build dir: build). Exit status 0 only if every
block of every page ran with exit status 0 and every expectation held.

The convention, visible in the page source (MyST comments, not rendered):

- Every fenced block whose language is ``sh`` or ``python`` is run, in page order, in a fresh
  directory per page (``BUILD_DIR/docs/snippets/<page>/``), so later blocks see the files that
  earlier ones wrote. ``sh`` blocks run under ``bash -e -o pipefail``; ``python`` blocks under
  /usr/bin/python3. The environment has ``BUILD_DIR`` first on PATH (so ``rbc`` is the built
  executable), ``PYTHONPATH=BUILD_DIR/python`` (so ``import rbc`` is the built package),
  ``RBC_BUILD_DIR`` and ``RBC_SOURCE_DIR`` (the build and source trees), ``MPLBACKEND=Agg`` and
  ``OMP_WAIT_POLICY=passive``.
- A line ``% no-run: REASON`` right before a block leaves that block out (the reason is
  printed). Blocks of other languages (``text``, ``cmake``, ``cpp``, ``console``) are never run.
- Lines ``% expect: ...`` after a block (blank lines may come between) check what it produced.
  A number is compared as ``|measured - VALUE| <= TOL``:

  ``% expect: stdout /REGEX/ VALUE +- TOL``     first capture group of REGEX in the block's stdout
  ``% expect: json FILE PATH VALUE +- TOL``      PATH like ``points[2].axial_um`` in a JSON file
  ``% expect: csv FILE COLUMN[ROW] VALUE +- TOL`` ROW an index (0 = first data row, -1 = last)
                                                 or KEY=VALUE (the row whose KEY column equals
                                                 VALUE); lines starting with # are comments
  ``% expect: file FILE``                        FILE exists and is not empty
  ``% expect: exit CODE``                        the block exits with CODE (default 0)
"""
from __future__ import annotations

import argparse
import csv
import json
import math
import os
import pathlib
import re
import shutil
import subprocess
import sys
import time
from dataclasses import dataclass, field

DOCS = pathlib.Path(__file__).resolve().parent
ROOT = DOCS.parent
RUN_LANGUAGES = {"sh": "sh", "bash": "sh", "python": "python"}
FENCE = re.compile(r"^(?P<fence>`{3,}|~{3,})\s*(?P<info>[^`\s]*)")
BLOCK_TIMEOUT_S = 300


def default_pages() -> list[pathlib.Path]:
    return ([DOCS / "getting-started" / "first-run.md"] + sorted((DOCS / "tutorials").glob("*.md"))
            + [DOCS / "validation" / "determinism.md"])


@dataclass
class Block:
    page: pathlib.Path
    line: int
    language: str  # "sh" | "python"
    text: str
    skip: str = ""
    expects: list[str] = field(default_factory=list)


def parse_page(page: pathlib.Path) -> list[Block]:
    """The runnable blocks of a MyST page with their no-run reasons and expectations."""
    lines = page.read_text().splitlines()
    blocks: list[Block] = []
    pending_skip = ""
    last: Block | None = None
    i = 0
    while i < len(lines):
        line = lines[i]
        m = FENCE.match(line.strip())
        if m:
            fence, info = m.group("fence"), m.group("info").lower()
            body = []
            i += 1
            while i < len(lines) and not lines[i].strip().startswith(fence):
                body.append(lines[i])
                i += 1
            lang = RUN_LANGUAGES.get(info)
            if lang:
                last = Block(page, i - len(body), lang, "\n".join(body) + "\n", pending_skip)
                blocks.append(last)
            else:
                last = None
            pending_skip = ""
        elif line.startswith("% no-run:"):
            pending_skip = line.split(":", 1)[1].strip() or "no reason given"
        elif line.startswith("% expect:"):
            if last is None:
                raise SystemExit(f"{page}:{i + 1}: '% expect:' does not follow a runnable block")
            last.expects.append(line.split(":", 1)[1].strip())
        elif line.strip() and not line.startswith("%"):
            last, pending_skip = None, ""  # prose ends a block's expectations
        i += 1
    return blocks


NUMBER = r"([-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?)"


def _value_and_tolerance(rest: str) -> tuple[float, float]:
    m = re.fullmatch(NUMBER + r"\s*\+-\s*" + NUMBER, rest.strip())
    if not m:
        raise ValueError(f"expected 'VALUE +- TOL', got '{rest.strip()}'")
    return float(m.group(1)), float(m.group(2))


def _json_path(data, path: str):
    for part in re.findall(r"[^.\[\]]+|\[-?\d+\]", path):
        data = data[int(part[1:-1])] if part.startswith("[") else data[part]
    return data


def _csv_value(file: pathlib.Path, selector: str) -> float:
    m = re.fullmatch(r"([^\[]+)\[([^\]]+)\]", selector)
    if not m:
        raise ValueError(f"expected COLUMN[ROW], got '{selector}'")
    column, row = m.group(1), m.group(2)
    with open(file, newline="") as f:
        rows = list(csv.DictReader(line for line in f if not line.startswith("#")))
    if "=" in row:
        key, want = row.split("=", 1)
        hits = [r for r in rows if math.isclose(float(r[key]), float(want), abs_tol=1e-9)]
        if len(hits) != 1:
            raise ValueError(f"{len(hits)} rows of {file.name} have {key} = {want}")
        return float(hits[0][column])
    return float(rows[int(row)][column])


def check(expect: str, stdout: str, cwd: pathlib.Path) -> tuple[bool, str]:
    """Whether one expectation holds, and what was measured."""
    kind, _, rest = expect.partition(" ")
    try:
        if kind == "stdout":
            m = re.match(r"\s*/(.*)/\s+(.*)$", rest)
            if not m:
                raise ValueError("expected 'stdout /REGEX/ VALUE +- TOL'")
            value, tol = _value_and_tolerance(m.group(2))
            hit = re.search(m.group(1), stdout, re.MULTILINE)
            if not hit:
                return False, f"/{m.group(1)}/ not found in stdout"
            got = float(hit.group(1))
        elif kind == "json":
            file, path, tail = rest.split(None, 2)
            value, tol = _value_and_tolerance(tail)
            got = float(_json_path(json.loads((cwd / file).read_text()), path))
        elif kind == "csv":
            file, selector, tail = rest.split(None, 2)
            value, tol = _value_and_tolerance(tail)
            got = _csv_value(cwd / file, selector)
        elif kind == "file":
            f = cwd / rest.strip()
            ok = f.is_file() and f.stat().st_size > 0
            return ok, f"{rest.strip()} {'exists' if ok else 'missing or empty'}"
        else:
            return False, f"unknown expectation kind '{kind}'"
    except (OSError, KeyError, IndexError, ValueError, TypeError) as e:
        return False, f"cannot read: {e}"
    ok = math.isfinite(got) and abs(got - value) <= tol
    return ok, f"measured {got:.6g}, stated {value:g} +- {tol:g}"


def _shown(page: pathlib.Path) -> str:
    return str(page.relative_to(ROOT)) if page.is_relative_to(ROOT) else str(page)


def run_page(page: pathlib.Path, build: pathlib.Path, env: dict[str, str]) -> tuple[int, int]:
    """Runs one page's blocks; returns (blocks run, failures)."""
    blocks = parse_page(page)
    work = build / "docs" / "snippets" / page.stem
    shutil.rmtree(work, ignore_errors=True)
    work.mkdir(parents=True)
    failures = ran = 0
    page_start = time.monotonic()
    for n, b in enumerate(blocks):
        where = f"{_shown(page)}:{b.line}"
        if b.skip:
            print(f"  skip {where} ({b.skip})")
            continue
        script = work / f"block_{n:02d}.{'sh' if b.language == 'sh' else 'py'}"
        script.write_text(b.text)
        cmd = (["bash", "-e", "-o", "pipefail", script.name] if b.language == "sh"
               else ["/usr/bin/python3", script.name])
        start = time.monotonic()
        try:
            p = subprocess.run(cmd, cwd=work, env=env, capture_output=True, text=True,
                               timeout=BLOCK_TIMEOUT_S)
            code, out, err = p.returncode, p.stdout, p.stderr
        except subprocess.TimeoutExpired as e:
            code, out, err = -1, e.stdout or "", f"timed out after {BLOCK_TIMEOUT_S} s"
            out = out.decode() if isinstance(out, bytes) else out
        ran += 1
        (work / f"{script.name}.stdout").write_text(out)
        (work / f"{script.name}.stderr").write_text(err if isinstance(err, str) else err.decode())
        want_exit = 0
        checks = []
        for e in b.expects:
            if e.startswith("exit "):
                want_exit = int(e.split()[1])
            else:
                checks.append(e)
        ok = code == want_exit
        status = [f"exit {code}" + ("" if ok else f" (expected {want_exit})")]
        for e in checks:
            good, what = check(e, out, work)
            ok &= good
            status.append(("ok: " if good else "MISMATCH: ") + f"{e} -> {what}")
        print(f"  {'ok  ' if ok else 'FAIL'} {where} {b.language} "
              f"({time.monotonic() - start:.1f} s)")
        for s in status[1:] if ok else status:
            print(f"       {s}")
        if not ok:
            failures += 1
            tail = (err if isinstance(err, str) else "").strip().splitlines()[-15:]
            print("       stderr (last lines):\n         " + "\n         ".join(tail))
    print(f"  {page.name}: {ran} blocks in {time.monotonic() - page_start:.1f} s, "
          f"{failures} failed")
    return ran, failures


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--build", default=str(ROOT / "build"), help="build directory (default build)")
    ap.add_argument("pages", nargs="*", help="pages to run (default docs/tutorials/*.md)")
    a = ap.parse_args()
    build = pathlib.Path(a.build).resolve()
    if not (build / "rbc").is_file():
        print(f"run_snippets: {build / 'rbc'} not found: build the targets rbc and rbc_python",
              file=sys.stderr)
        return 2
    pages = [pathlib.Path(p).resolve() for p in a.pages] or default_pages()
    env = dict(os.environ)
    env.update({
        "PATH": f"{build}{os.pathsep}{env.get('PATH', '')}",
        "PYTHONPATH": str(build / "python"),
        "RBC_BUILD_DIR": str(build),
        "RBC_SOURCE_DIR": str(ROOT),
        "MPLBACKEND": "Agg",
        "OMP_WAIT_POLICY": env.get("OMP_WAIT_POLICY", "passive"),
    })
    start = time.monotonic()
    total = failed = 0
    for page in pages:
        print(_shown(page))
        ran, bad = run_page(page, build, env)
        total += ran
        failed += bad
    print(f"{len(pages)} pages, {total} blocks, {time.monotonic() - start:.0f} s")
    print(f"snippets: {total - failed} passed, {failed} failed")
    return 1 if failed or total == 0 else 0


if __name__ == "__main__":
    sys.exit(main())
