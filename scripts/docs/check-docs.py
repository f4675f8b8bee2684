#!/usr/bin/env python3
"""Checks the documentation (make docs-check, part of make test).

1. Every file in docs/ has at most 600 lines.
2. Neither docs/, README.md nor the source cites a stop or an issue number: the docs say the
   reason instead, and the history is in CHANGELOG.md and git.
3. Every relative link in README.md, CHANGELOG.md and docs/ names a file that exists and, with
   a #fragment, a heading of that file (GitHub's anchors).
4. Every ```sh block of the guides (docs/guides/*.md) and of README.md runs: each block is run
   by bash -e from a scratch folder that sees the repository's scenes/, viewer/, scripts/ and
   runtime/ (read-only use) and has an empty out/, with target/release first on PATH. Blocks
   whose info string is `sh skip …` need what this check cannot have (a display, Blender,
   Slurm, a browser, a second build); the words after `skip` say which make target covers
   them.

    python3 scripts/docs/check-docs.py [--no-run] [--keep] [GUIDE.md ...]

--no-run does 1-3 only; --keep leaves the scratch folder and prints it.
"""

import os
import re
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
MAX_LINES = 600
# The word stop(s) or issue(s), then a space or a hyphen, an optional #, and a number.
CITATION = re.compile(r"\b([Ss]tops?|[Ii]ssues?)[ -]#?[0-9]+")
SOURCE_DIRS = ["baker", "viewer", "runtime", "scripts", "tests", "scenes", "embree-sys"]
SOURCE_EXT = {".rs", ".py", ".sh", ".js", ".mjs", ".html", ".toml", ".scene", ".wgsl", ".md"}
LINKED = ["README.md", "CHANGELOG.md"]


def fail(problems, message):
    problems.append(message)


def doc_files():
    return sorted((ROOT / "docs").rglob("*.md"))


def check_lengths(problems):
    for path in doc_files():
        n = len(path.read_text(encoding="utf-8").splitlines())
        if n > MAX_LINES:
            fail(problems, f"{path.relative_to(ROOT)}: {n} lines (at most {MAX_LINES})")


def tracked_files():
    out = subprocess.run(["git", "ls-files"], cwd=ROOT, capture_output=True, text=True)
    if out.returncode != 0:  # not a git checkout: walk the folders instead
        return [p.relative_to(ROOT).as_posix() for d in SOURCE_DIRS + ["docs"]
                for p in (ROOT / d).rglob("*") if p.is_file()] + ["README.md", "Makefile"]
    return out.stdout.splitlines()


def check_citations(problems):
    for name in tracked_files():
        if name == "CHANGELOG.md" or name.startswith("baker/tests/fuzz-corpus/"):
            continue
        path = ROOT / name
        top = name.split("/")[0]
        wanted = (name in ("README.md", "Makefile") or top == "docs"
                  or (top in SOURCE_DIRS and path.suffix in SOURCE_EXT))
        if not wanted or not path.is_file():
            continue
        try:
            text = path.read_text(encoding="utf-8")
        except UnicodeDecodeError:
            continue
        for number, line in enumerate(text.splitlines(), 1):
            if CITATION.search(line):
                fail(problems, f"{name}:{number}: cites a stop or an issue: {line.strip()[:100]}")


def slug(heading):
    """GitHub's anchor of a heading: lower case, punctuation dropped, spaces to hyphens."""
    text = re.sub(r"`", "", heading.strip().lower())
    text = re.sub(r"[^\w\- ]", "", text)
    return text.replace(" ", "-")


def anchors(path, cache={}):
    if path not in cache:
        found, seen, fenced = set(), {}, False
        for line in path.read_text(encoding="utf-8").splitlines():
            if line.startswith("```"):
                fenced = not fenced
            m = re.match(r"#{1,6} (.*)", line)
            if m and not fenced:
                base = slug(m.group(1))
                n = seen.get(base, 0)
                seen[base] = n + 1
                found.add(base if n == 0 else f"{base}-{n}")
        cache[path] = found
    return cache[path]


LINK = re.compile(r"\]\(([^)\s]+)\)")


def check_links(problems):
    files = [ROOT / n for n in LINKED if (ROOT / n).exists()] + doc_files()
    for path in files:
        fenced = False
        for number, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
            if line.startswith("```"):
                fenced = not fenced
            if fenced:
                continue
            for target in LINK.findall(line):
                if re.match(r"[a-z]+:", target):
                    continue  # http:, https:, mailto:
                file_part, _, fragment = target.partition("#")
                dest = (path.parent / file_part).resolve() if file_part else path
                where = f"{path.relative_to(ROOT)}:{number}"
                if not dest.exists():
                    fail(problems, f"{where}: link to a missing file: {target}")
                elif fragment and dest.suffix == ".md" and fragment not in anchors(dest):
                    fail(problems, f"{where}: link to a missing heading: {target}")


def sh_blocks(path):
    """(first line number, info string, code) of every ```sh block."""
    blocks, lines = [], path.read_text(encoding="utf-8").splitlines()
    i = 0
    while i < len(lines):
        m = re.match(r"```(sh\b.*)$", lines[i])
        if m:
            start, info, code = i + 1, m.group(1).strip(), []
            i += 1
            while i < len(lines) and not lines[i].startswith("```"):
                code.append(lines[i])
                i += 1
            blocks.append((start, info, "\n".join(code)))
        i += 1
    return blocks


def run_blocks(guides, keep):
    release = ROOT / "target" / "release"
    if not (release / "prt-bake").exists():
        print("docs-check: target/release/prt-bake is missing (make build)", file=sys.stderr)
        return ["target/release/prt-bake missing"]
    scratch = Path(tempfile.mkdtemp(prefix="prt-docs-"))
    for name in ["scenes", "viewer", "scripts", "runtime"]:
        os.symlink(ROOT / name, scratch / name)
    (scratch / "target").mkdir()
    os.symlink(release, scratch / "target" / "release")
    env = dict(os.environ, PATH=f"{release}:{os.environ['PATH']}")
    problems, ran, skipped, total = [], 0, [], time.monotonic()
    for guide in guides:
        for start, info, code in sh_blocks(guide):
            where = f"{guide.relative_to(ROOT)}:{start}"
            if info != "sh":
                skipped.append(f"{where} ({info[2:].strip()})")
                continue
            (scratch / "out").mkdir(exist_ok=True)
            t0 = time.monotonic()
            done = subprocess.run(["bash", "-e", "-o", "pipefail", "-c", code], cwd=scratch,
                                  env=env, capture_output=True, text=True)
            ran += 1
            took = time.monotonic() - t0
            if done.returncode != 0:
                tail = (done.stdout + done.stderr).strip().splitlines()[-8:]
                fail(problems, f"{where}: exit {done.returncode} after {took:.1f} s:\n    "
                     + "\n    ".join(tail))
            else:
                print(f"docs-check: {where} ok ({took:.1f} s)")
    print(f"docs-check: {ran} blocks ran in {time.monotonic() - total:.1f} s; "
          f"{len(skipped)} skipped:")
    for s in skipped:
        print(f"    {s}")
    if keep:
        print(f"docs-check: scratch folder kept: {scratch}")
    else:
        shutil.rmtree(scratch)
    return problems


def main():
    args = sys.argv[1:]
    run = "--no-run" not in args
    keep = "--keep" in args
    named = [ROOT / a for a in args if not a.startswith("--")]
    problems = []
    check_lengths(problems)
    check_citations(problems)
    check_links(problems)
    if run:
        guides = named or sorted((ROOT / "docs" / "guides").glob("*.md")) + [ROOT / "README.md"]
        problems += run_blocks(guides, keep)
    for p in problems:
        print(f"docs-check: {p}", file=sys.stderr)
    if problems:
        print(f"docs-check: {len(problems)} problem(s)", file=sys.stderr)
        return 1
    print("docs-check: passed")
    return 0


if __name__ == "__main__":
    sys.exit(main())
