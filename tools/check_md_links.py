#!/usr/bin/env python3
"""Checks that the links of Markdown files resolve: a relative link names a file that exists, and a
#anchor names a heading of its target (GitHub's slugs: lower case, punctuation dropped, spaces to
hyphens, -1, -2 for repeated headings). Links in code blocks and to URLs are not checked.

    tools/check_md_links.py [FILE.md ...]      (default: every Markdown file git tracks)

Prints each link that does not resolve; exit status 1 if there is one."""
import os
import re
import subprocess
import sys


def slugs(path):
    seen, out, fence = {}, set(), False
    for line in open(path, encoding="utf-8"):
        if line.startswith("```"):
            fence = not fence
            continue
        m = None if fence else re.match(r"^(#{1,6})\s+(.*?)\s*#*\s*$", line)
        if not m:
            continue
        text = re.sub(r"`([^`]*)`", r"\1", m.group(2))
        text = re.sub(r"\[([^\]]*)\]\([^)]*\)", r"\1", text)
        slug = re.sub(r"[^\w\- ]", "", text.strip().lower()).replace(" ", "-")
        n = seen.get(slug, 0)
        seen[slug] = n + 1
        out.add(slug if n == 0 else f"{slug}-{n}")
    return out


def main(paths):
    bad = 0
    for path in paths:
        text = re.sub(r"```.*?```", "", open(path, encoding="utf-8").read(), flags=re.S)
        for target in re.findall(r"\]\(([^)\s]+)\)", text):
            if re.match(r"^[a-z]+:", target):
                continue
            name, _, anchor = target.partition("#")
            file = os.path.normpath(os.path.join(os.path.dirname(path), name)) if name else path
            if not os.path.exists(file):
                print(f"{path}: no file {target}")
                bad += 1
            elif anchor and file.endswith(".md") and anchor not in slugs(file):
                print(f"{path}: no heading for {target}")
                bad += 1
    return 1 if bad else 0


if __name__ == "__main__":
    files = sys.argv[1:] or [
        f for f in subprocess.run(["git", "ls-files", "*.md"], capture_output=True, text=True,
                                  check=True).stdout.split() if "node_modules" not in f]
    sys.exit(main(files))
