#!/usr/bin/env python3
"""Checks the README and the guide (docs/src) for links that lead nowhere.

- Every relative link and image in README.md and docs/src/**/*.md names a file that
  exists, and its #anchor (if any) a heading of that page (as mdBook and GitHub make
  anchors: lower case, punctuation dropped, spaces to dashes).
- A page of the guide links only inside docs/src: mdBook copies nothing else, so a link
  out of it would be broken in the built book.
- No markdown file, and no comment in the sources, scripts or examples, points outside the
  repository (a path into ../shared other than the shared test data ../shared/data, or
  DESIGN.md), and no markdown file cites an issue number.

Prints one line per problem and exits 1 if there is any. Run from anywhere:
python3 .ci/check_links.py
"""

import re
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
BOOK = ROOT / "docs" / "src"

LINK = re.compile(r"!?\[(?:[^\[\]]|\[[^\]]*\])*\]\(\s*<?([^)\s>]+)>?(?:\s+\"[^\"]*\")?\s*\)")
FENCE = re.compile(r"^\s*(```|~~~)")
HEADING = re.compile(r"^(#{1,6})\s+(.*?)\s*#*\s*$")
OUTSIDE = re.compile(r"\.\./shared(?!/data)|DESIGN\.md")
ISSUE = re.compile(r"\bissue\s+#?\d+|\bissues/\d+", re.IGNORECASE)
SOURCE_SUFFIXES = {".rs", ".py", ".toml", ".sh", ".mjs", ".js", ".yaml", ".yml"}


def prose(text):
    """The lines of a markdown text outside fenced code blocks, with their numbers."""
    fenced = False
    for number, line in enumerate(text.splitlines(), 1):
        if FENCE.match(line):
            fenced = not fenced
            continue
        if not fenced:
            yield number, line


def slug(heading):
    """The anchor mdBook (and GitHub) give a heading."""
    text = re.sub(r"<[^>]+>", "", heading)
    text = re.sub(r"\[([^\]]*)\]\([^)]*\)", r"\1", text)
    text = text.strip().lower()
    text = "".join(c for c in text if c.isalnum() or c in " -_")
    return text.replace(" ", "-")


def anchors(page):
    found = set()
    for _, line in prose(page.read_text(encoding="utf-8")):
        m = HEADING.match(line)
        if m:
            base = slug(m.group(2))
            name, n = base, 1
            while name in found:
                name = f"{base}-{n}"
                n += 1
            found.add(name)
    return found


def check_page(page, problems):
    text = page.read_text(encoding="utf-8")
    in_book = BOOK in page.parents
    where = page.relative_to(ROOT)
    for number, line in prose(text):
        code_free = re.sub(r"`[^`]*`", "", line)
        for target in LINK.findall(code_free):
            if re.match(r"^[a-z][a-z0-9+.-]*:", target):  # https:, mailto:, ...
                continue
            path, _, anchor = target.partition("#")
            dest = (page.parent / path).resolve() if path else page
            if not dest.exists():
                problems.append(f"{where}:{number}: {target}: no such file")
                continue
            if in_book and BOOK not in dest.parents and dest != BOOK:
                problems.append(
                    f"{where}:{number}: {target}: leaves docs/src (mdBook copies only docs/src)"
                )
            if anchor and dest.suffix == ".md" and anchor not in anchors(dest):
                problems.append(f"{where}:{number}: {target}: no heading #{anchor} there")
    for number, line in enumerate(text.splitlines(), 1):
        if OUTSIDE.search(line):
            problems.append(f"{where}:{number}: points outside the repository: {line.strip()}")
        if ISSUE.search(line):
            problems.append(f"{where}:{number}: cites an issue: {line.strip()}")


def comments(path):
    """The comment lines of a source file, with their numbers (a simple reading: `//` in
    Rust and JavaScript, `#` elsewhere)."""
    slashes = path.suffix in {".rs", ".mjs", ".js"}
    for number, line in enumerate(path.read_text(encoding="utf-8", errors="replace").splitlines(), 1):
        stripped = line.strip()
        if slashes and "//" in stripped:
            yield number, stripped[stripped.index("//"):]
        elif not slashes and "#" in stripped:
            yield number, stripped[stripped.index("#"):]


def tracked():
    out = subprocess.run(
        ["git", "ls-files", "--cached", "--others", "--exclude-standard"],
        cwd=ROOT, capture_output=True, text=True, check=True,
    ).stdout
    return [ROOT / p for p in out.splitlines() if (ROOT / p).is_file()]


def main():
    problems = []
    files = tracked()
    pages = [ROOT / "README.md"] + sorted(BOOK.rglob("*.md"))
    for page in pages:
        check_page(page, problems)
    for path in files:
        if path.suffix == ".md" and path not in pages:
            for number, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
                if OUTSIDE.search(line):
                    problems.append(
                        f"{path.relative_to(ROOT)}:{number}: points outside the repository: {line.strip()}"
                    )
        is_test = "tests" in path.relative_to(ROOT).parts or path.parent.name == "benches"
        if path.suffix in SOURCE_SUFFIXES or path.parent.name == ".ci":
            for number, comment in comments(path):
                if OUTSIDE.search(comment) and not is_test:
                    problems.append(
                        f"{path.relative_to(ROOT)}:{number}: a comment points outside the repository: {comment}"
                    )
    for p in problems:
        print(p)
    checked = len(pages)
    if problems:
        print(f"check_links: {len(problems)} problem(s) in {checked} pages and the sources")
        return 1
    print(f"check_links: {checked} pages and the sources' comments: every link leads somewhere")
    return 0


if __name__ == "__main__":
    sys.exit(main())
