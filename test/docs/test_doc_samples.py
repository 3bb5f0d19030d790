# SPDX-License-Identifier: GPL-3.0-or-later
"""Every sample output in README.md and docs/ is checked against a run (test/support/
doc_samples.py): each fenced block without an info string is a marked sample, every marked
sample is checked by a test (a call doc_samples.check("NAME", ...) in test/ or scripts/), and
every sample a test checks exists. The checks themselves run where the commands run (the
conform suite, the flash tests, the labs...)."""
import re
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(REPO / "test" / "support"))
import doc_samples  # noqa: E402

CHECK_CALL = re.compile(r"doc_samples\.check\(\s*[\"']([a-z0-9-]+)[\"']")


def checked_names():
    """{name: file} of every doc_samples.check call in the tests and scripts."""
    found = {}
    for folder in ("test", "scripts"):
        for path in sorted((REPO / folder).rglob("*")):
            if path.is_file() and (path.suffix == ".py" or path.parent.name == "scripts"):
                try:
                    text = path.read_text()
                except UnicodeDecodeError:
                    continue
                for name in CHECK_CALL.findall(text):
                    found.setdefault(name, path.relative_to(REPO))
    return found


def test_every_output_block_is_a_marked_sample():
    unmarked = ["%s:%d" % (path.relative_to(REPO), line)
                for path in doc_samples.documents() for line, info, name, _ in doc_samples.blocks(path)
                if not info and not name]
    assert unmarked == [], ("fenced blocks without an info string and without a <!-- sample: NAME --> marker "
                            "(an output needs a marker and a test; anything else an info string such as text): %s"
                            % unmarked)


def test_every_sample_is_checked_by_a_test_and_every_check_has_its_sample():
    samples = doc_samples.samples()
    checked = checked_names()
    assert sorted(set(samples) - set(checked)) == [], "samples no test checks"
    assert {name: str(path) for name, path in checked.items() if name not in samples} == {}, \
        "checks of samples that are not in the docs"


def test_a_sample_matches_its_run_line_for_line_with_ellipses_for_what_it_leaves_out():
    m = doc_samples.matches
    assert m(["a", "b"], ["a", "b"])
    assert not m(["a", "b"], ["a", "b", "c"]), "a sample without ... shows the whole output"
    assert not m(["a", "c"], ["a", "b", "c"])
    assert m(["a", "...", "c"], ["a", "b", "b", "c"])
    assert m(["...", "b", "..."], ["a", "b", "c"])
    assert not m(["a", "...", "b"], ["a", "c"])
    assert not m(["b", "..."], ["a", "b"]), "the first line of a sample is the first of the output"
