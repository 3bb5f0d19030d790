# SPDX-License-Identifier: GPL-3.0-or-later
"""The sample outputs of README.md and docs/, checked against the runs that make them.

A sample is a fenced block with no info string, right after a marker line naming it:

    <!-- sample: conform-pass -->
    ```
    ax12 conform: /tmp/ax12 (pty), ID 1 at 1000000 bit/s, compared with profile ax12
    ...
    ```

(a fenced block that is not an output carries an info string: `sh`, `python`, `text`). The
test that runs the command a sample shows calls check(NAME, its output, ...): the sample's
lines must be the output's, in order and together, after `normalize` (a function of one line)
has masked in both what no two runs share (times, a pty's number), or alike by `same` (a
function of a sample line and an output line: figures of a real-time run within a tolerance);
a line `...` in the sample stands for any number of lines. test/docs/test_doc_samples.py checks that every such block has
a marker and every marker a test that checks it.

Each check also writes the output to <build>/doc-samples/NAME.txt; `python3
test/support/doc_samples.py --update NAME` puts that file's text into the sample (for
samples shown whole: no `...`, no notes).
"""
import difflib
import os
import re
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
MARKER = re.compile(r"^<!-- sample: ([a-z0-9-]+) -->\s*$")
FENCE = re.compile(r"^```(.*)$")
ELLIPSIS = "..."


def documents():
    """README.md and every Markdown file under docs/."""
    return [REPO / "README.md"] + sorted((REPO / "docs").rglob("*.md"))


def blocks(path):
    """[(first line number, info string, marker name or None, [lines])] of a Markdown file's
    fenced blocks."""
    out, lines = [], Path(path).read_text().splitlines()
    i, marker = 0, None
    while i < len(lines):
        m = MARKER.match(lines[i])
        if m:
            marker = m.group(1)
            i += 1
            continue
        fence = FENCE.match(lines[i])
        if fence:
            end = next(j for j in range(i + 1, len(lines)) if lines[j].startswith("```"))
            out.append((i + 1, fence.group(1).strip(), marker, lines[i + 1:end]))
            i, marker = end + 1, None
            continue
        if lines[i].strip():
            marker = None  # a marker names the block right after it
        i += 1
    return out


def samples():
    """{name: (path, first line number, lines)} of every marked block."""
    found = {}
    for path in documents():
        for line, _, name, text in blocks(path):
            if name:
                if name in found:
                    raise ValueError("sample %s is marked twice: %s:%d and %s:%d"
                                     % (name, found[name][0], found[name][1], path, line))
                found[name] = (path, line, text)
    return found


def build_dir():
    return Path(os.environ.get("AX12_BUILD_DIR") or REPO / "build")


def _segments(lines):
    """The sample's lines cut at its `...` lines: [(anchored at the start, lines, anchored at
    the end)]."""
    parts, current = [], []
    for line in lines:
        if line.strip() == ELLIPSIS:
            parts.append(current)
            current = []
        else:
            current.append(line)
    parts.append(current)
    return [(k == 0, part, k == len(parts) - 1) for k, part in enumerate(parts) if part]


def matches(sample, output, same=None):
    """Whether the sample's lines are the output's (`...` for any lines in between; without
    `...` at its start or end the sample starts or ends where the output does). Two lines are
    alike when equal, or when same(sample line, output line) says so."""
    same = same or (lambda a, b: a == b)
    at = 0
    for first, part, last in _segments(sample):
        starts = [at] if first else range(at, len(output) - len(part) + 1)
        for start in starts:
            block = output[start:start + len(part)]
            if (len(block) == len(part) and all(same(a, b) for a, b in zip(part, block))
                    and (not last or start + len(part) == len(output))):
                at = start + len(part)
                break
        else:
            return False
    return True


def check(name, produced, normalize=None, same=None):
    """Raises AssertionError unless sample `name` shows `produced` (text), both normalized line
    by line (and lines compared by same(sample line, output line) when given, for figures a
    real-time run gives within a tolerance); writes produced to <build>/doc-samples/NAME.txt
    first."""
    known = samples()
    assert name in known, "no sample marked %s in README.md or docs/" % name
    path, first_line, text = known[name]
    folder = build_dir() / "doc-samples"
    folder.mkdir(parents=True, exist_ok=True)
    (folder / (name + ".txt")).write_text(produced)
    normalize = normalize or (lambda s: s)
    sample = [s if s.strip() == ELLIPSIS else normalize(s.rstrip()) for s in text]
    output = [normalize(s.rstrip()) for s in produced.rstrip("\n").splitlines()]
    if not matches(sample, output, same):
        where = "%s:%d" % (path.relative_to(REPO), first_line)
        diff = "\n".join(difflib.unified_diff(sample, output, "%s (sample %s)" % (where, name), "the run",
                                              lineterm=""))
        raise AssertionError("sample %s (%s) is not what the run printed (normalized; the run's output is in %s):\n%s"
                             % (name, where, folder / (name + ".txt"), diff))


def update(name):
    """Puts <build>/doc-samples/NAME.txt into the sample's block."""
    path, first_line, text = samples()[name]
    produced = (build_dir() / "doc-samples" / (name + ".txt")).read_text().rstrip("\n").splitlines()
    lines = path.read_text().splitlines()
    lines[first_line:first_line + len(text)] = produced
    path.write_text("\n".join(lines) + "\n")
    print("%s:%d: sample %s updated" % (path.relative_to(REPO), first_line, name))


if __name__ == "__main__":
    if len(sys.argv) != 3 or sys.argv[1] != "--update":
        sys.exit("usage: doc_samples.py --update NAME   (after a test run wrote build/doc-samples/NAME.txt)")
    update(sys.argv[2])
