"""Every command of the README and of the reference pages in docs/ runs as written, in the order
a newcomer meets them, from the clone's root with the virtual environment activated, and every
recorded output is what the command prints today (tools/readme.py: numbers with a decimal point
aside). The pages' commands are the product's promises: a page of docs/ is run as the README is
(`readme.pages()`); a block that is only an example for another site is a `text` block."""

from __future__ import annotations

import pytest

from tools import readme

PAGES = readme.pages()
BLOCKS = [b for page in PAGES for b in readme.blocks(page.read_text(), page)]
README_BLOCKS = [b for b in BLOCKS if b.page == readme.README]


def test_the_readme_is_made_of_runnable_blocks():
    """The README's commands are in sh and console blocks (text blocks are another site's
    examples), and they cover the commands of the tool, one example each at least."""
    commands = " ".join(c.text for b in README_BLOCKS for c in b.commands)
    assert {b.kind for b in README_BLOCKS} == {"sh", "console"}
    for word in ("make demo", "pathcheck info", "pathcheck allowable", "pathcheck map",
                 "check-gcode", "pathcheck serve", "pathcheck call", "pathcheck batch",
                 "pathcheck report", "pathcheck store prune", "pathcheck flank",
                 "pathcheck view"):
        assert word in commands, word


def test_the_reference_pages_blocks_are_run_too():
    """The command pages are among the pages run, after the README (whose outputs they read),
    and their commands are parsed like the README's."""
    names = [p.relative_to(readme.REPO).as_posix() for p in PAGES]
    assert names[0] == "README.md"
    assert "docs/commands/check.md" in names and "docs/commands/check-gcode.md" in names
    docs = [b for b in BLOCKS if b.page != readme.README]
    assert {b.kind for b in docs} <= {"sh", "console"}
    ran = " ".join(c.text for b in docs for c in b.commands)
    assert "--strategy contact-order" in ran and "--machine-check" in ran


def test_normalised_outputs_keep_counts_and_drop_decimals():
    """What the comparison keeps: 62 gouges are not 61, 6.81 s is 9.07 s."""
    same = readme.normalised(["gouge 62  time 6.81 s", "\u2501\u2501\u2501 x"])
    assert same == readme.normalised(["gouge 62 time 9.07 s", "\u2501 x"])
    assert same != readme.normalised(["gouge 61 time 6.81 s", "\u2501 x"])


@pytest.fixture(scope="module")
def outcomes(tmp_path_factory, realdata):
    """Every block run once, in the pages' order (later blocks use what earlier ones wrote,
    as a reader following the pages does), with its own results store."""
    env = readme.environment(tmp_path_factory.mktemp("readme") / "results.sqlite")
    return {b.name: readme.run_block(b, env) for b in BLOCKS}


@pytest.mark.slow
@pytest.mark.timeout(1800)  # the first block's setup runs every block (a few minutes on 2 cores)
@pytest.mark.parametrize("block", BLOCKS, ids=[b.name for b in BLOCKS])
def test_block_runs_as_written(block, outcomes):
    problems = [p for o in outcomes[block.name] if (p := o.problem(block.kind))]
    assert not problems, "\n\n".join(problems)
