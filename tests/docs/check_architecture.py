#!/usr/bin/env python3
"""Keeps docs/ARCHITECTURE.md a short, true map (and docs/design/*.md true).

Fails (exit 1, one line per problem) when
- docs/ARCHITECTURE.md has more than 320 lines, or a docs/design/*.md more than 250;
- any line of them is wider than 100 columns;
- they name a repository path that does not exist: a word that looks like `dir/file.ext` or
  `dir/` (relative to the repository's root; `{a,b}` alternatives are expanded). Words starting
  with `/` (HTTP paths, /proc), `~` or `$`, URLs, placeholders (`<level>`, `*`) and numbers
  (`1.1.1/1.3.0`) are not paths;
- a docs/design/*.md is not named in docs/ARCHITECTURE.md (the map points to every design note).

Usage: check_architecture.py REPO_ROOT [FILE...]  (FILE: another map to check, for tests)
"""

import re
import sys
from pathlib import Path

MAP_MAX_LINES = 320
DESIGN_MAX_LINES = 250
MAX_COLUMNS = 100

# Split prose into words: whitespace, markdown/code punctuation and quotes end a word.
SEPARATORS = re.compile(r"[\s`()\[\]\"',;|]+")
# A path word: components of letters, digits, '_', '-', '.', '{', '}' separated by '/'.
PATH_WORD = re.compile(r"^[A-Za-z0-9_.{}-]+(/[A-Za-z0-9_.{}-]+)*/?$")
BRACES = re.compile(r"\{([^{}]*)\}")


def expand(word):
    """`a/B.{hpp,cpp}` -> [`a/B.hpp`, `a/B.cpp`]."""
    m = BRACES.search(word)
    if not m:
        return [word]
    out = []
    for alt in m.group(1).split(","):
        out += expand(word[: m.start()] + alt + word[m.end():])
    return out


def path_words(line):
    for raw in SEPARATORS.split(line):
        word = raw.rstrip(".:!?")
        if "/" not in word or "://" in raw or word.startswith(("/", "~", "$")):
            continue
        if not PATH_WORD.match(word):
            continue  # placeholders such as <root>/<level>, globs, options
        parts = word.rstrip("/").split("/")
        if not all(re.search(r"[A-Za-z]", c) for c in parts):
            continue  # numbers such as 1.1.1/1.3.0 or 1/256
        last = parts[-1]
        looks_like_file = re.search(r"[A-Za-z0-9_-]\.[A-Za-z0-9]+$", last) is not None
        if word.endswith("/") or looks_like_file:
            yield word


def check(path, root, max_lines):
    problems = []
    text = path.read_text(encoding="utf-8")
    lines = text.split("\n")
    if lines and lines[-1] == "":
        lines.pop()
    name = path.relative_to(root) if path.is_relative_to(root) else path
    if len(lines) > max_lines:
        problems.append(f"{name}: {len(lines)} lines, more than {max_lines}")
    for n, line in enumerate(lines, 1):
        if len(line) > MAX_COLUMNS:
            problems.append(f"{name}:{n}: {len(line)} columns, more than {MAX_COLUMNS}")
        for word in path_words(line):
            for p in expand(word):
                if not (root / p).exists():
                    problems.append(f"{name}:{n}: no such path in the repository: {p}")
    return problems, text


def main(argv):
    if len(argv) < 2:
        print(__doc__)
        return 2
    root = Path(argv[1]).resolve()
    maps = [Path(a).resolve() for a in argv[2:]] or [root / "docs" / "ARCHITECTURE.md"]
    problems = []
    map_text = ""
    for m in maps:
        p, t = check(m, root, MAP_MAX_LINES)
        problems += p
        map_text += t
    for design in sorted((root / "docs" / "design").glob("*.md")):
        p, _ = check(design, root, DESIGN_MAX_LINES)
        problems += p
        rel = f"docs/design/{design.name}"
        if rel not in map_text:
            problems.append(f"{rel}: not named in the map ({', '.join(str(m) for m in maps)})")
    for p in problems:
        print(p)
    if problems:
        print(f"FAILED: {len(problems)} problem(s)")
        return 1
    print("ok: the map is short and every path it names exists")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
