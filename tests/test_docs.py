"""The documentation's shape: the README a user's guide within 500 lines, one reference page per
command, the section markers paired, every relative link and anchor leading somewhere, and the
source papers cited by author and year with their full citations in docs/MATH.md's References
(never by the file name the project once kept them under)."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
README = REPO / "README.md"
DOCS = REPO / "docs"
PAGES = [README, REPO / "CHANGELOG.md", *sorted(DOCS.rglob("*.md"))]
_MARKER = re.compile(r"<!-- ([\w-]+):(begin|end) -->")
_LINK = re.compile(r"\]\(([^)\s]+)\)")
_FENCE = re.compile(r"^```.*?^```", re.M | re.S)


def _anchors(text: str) -> set[str]:
    """GitHub's anchors of a page's headings: lower case, punctuation dropped, spaces -> '-'."""
    out = set()
    for title in re.findall(r"^#{1,6} (.+)$", _FENCE.sub("", text), re.M):
        slug = re.sub(r"[^\w\- ]", "", title.strip().lower()).replace(" ", "-")
        out.add(slug)
    return out


def test_the_readme_is_a_guide_within_500_lines():
    text = README.read_text()
    assert len(text.splitlines()) <= 500
    for heading in ("## Installing", "## First run", "## The commands", "## Verdicts",
                    "## Exit codes", "## The service", "## Results store", "## Benchmarks"):
        assert heading in text, heading


def test_one_benchmark_table_in_the_readme_with_machine_and_date():
    """Measurements in the README: the one table of its Benchmarks section, which names the
    machine and the date it was measured on."""
    text = README.read_text()
    bench = text[text.index("## Benchmarks"):]
    assert re.search(r"20\d\d-\d\d-\d\d", bench) and "cores" in bench
    tables = re.findall(r"^\|---", bench, re.M)
    assert len(tables) == 1
    assert "session" not in text.lower()


def test_every_command_has_a_reference_page():
    from checker.cli import cli

    pages = {p.stem for p in (DOCS / "commands").glob("*.md")}
    served = {"call": "serve"}  # `call` is the client of `serve`: one page
    missing = {c for c in cli.commands if served.get(c, c) not in pages}
    assert not missing, f"commands without a page in docs/commands/: {sorted(missing)}"


@pytest.mark.parametrize("page", PAGES, ids=[p.relative_to(REPO).as_posix() for p in PAGES])
def test_section_markers_pair_up(page):
    """Each `<!-- name:begin -->` is closed by its `<!-- name:end -->` before the next one of
    that name opens, and no end is without its begin."""
    open_: dict[str, int] = {}
    for m in _MARKER.finditer(page.read_text()):
        name, which = m.groups()
        if which == "begin":
            assert name not in open_, f"{name}: begun twice"
            open_[name] = m.start()
        else:
            assert name in open_, f"{name}: ended without a begin"
            del open_[name]
    assert not open_, f"not ended: {sorted(open_)}"


@pytest.mark.parametrize("page", PAGES, ids=[p.relative_to(REPO).as_posix() for p in PAGES])
def test_relative_links_lead_somewhere(page):
    """A link to a file of the repository names one that exists, and its #anchor a heading of
    that page."""
    bad = []
    for target in _LINK.findall(_FENCE.sub("", page.read_text())):
        if re.match(r"[a-z]+:", target):
            continue  # https:, mailto:
        path, _, anchor = target.partition("#")
        dest = (page.parent / path).resolve() if path else page
        if not dest.exists():
            bad.append(f"{target}: no such file")
        elif anchor and dest.is_file() and anchor not in _anchors(dest.read_text()):
            bad.append(f"{target}: no heading with that anchor")
    assert not bad, "\n".join(bad)


def test_the_papers_are_cited_by_author_and_year():
    """docs/MATH.md's References give the five papers in full; no page (but the changelog's
    history), docstring or output names a paper by its old file number ("seed 002")."""
    math = (DOCS / "MATH.md").read_text()
    refs = math[math.index("## References"):]
    for who in ("Liu (2007)", "Gong and Wang (2009)", "Jun, Lee and Cha (2002)",
                "Liu et al. (n.d.)", "Hwang et al. (2011)"):
        assert who in refs, who
    for title in ("Automated Cutter Size and Orientation Determinations",
                  "Optimize tool paths of flank milling", "tool orientations for 5-axis",
                  "flat-end cutter", "Continuity control method of cutter posture"):
        assert title.lower() in refs.lower().replace("\n  ", " "), title
    seeds = re.compile(r"\bseeds? 00\d", re.I)
    history = REPO / "CHANGELOG.md"  # may quote an output as it was
    files = [*(p for p in PAGES if p != history), *(REPO / "checker").rglob("*.py"),
             *(REPO / "checker").rglob("*.toml"), *(REPO / "benchmarks").rglob("*.py"),
             REPO / "samples" / "README.md"]
    found = [f"{f.relative_to(REPO)}:{n}" for f in files
             for n, line in enumerate(f.read_text().splitlines(), 1) if seeds.search(line)]
    assert not found, found
