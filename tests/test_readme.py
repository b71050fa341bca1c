"""Every command of the README runs as written, in the order a newcomer meets them, from the
clone's root with the virtual environment activated, and every recorded output is what the
command prints today (tools/readme.py: numbers with a decimal point aside)."""

from __future__ import annotations

import pytest

from tools import readme

BLOCKS = readme.blocks(readme.README.read_text())


def test_the_readme_is_made_of_runnable_blocks():
    """The page's commands are in sh and console blocks (text blocks are another site's
    examples), and they cover the commands of the tool."""
    commands = " ".join(c.text for b in BLOCKS for c in b.commands)
    assert {b.kind for b in BLOCKS} == {"sh", "console"}
    for word in ("make demo", "pathcheck info", "pathcheck allowable", "pathcheck map",
                 "check-gcode", "pathcheck serve", "pathcheck call", "pathcheck batch",
                 "pathcheck report", "pathcheck store prune", "pathcheck flank"):
        assert word in commands, word


def test_normalised_outputs_keep_counts_and_drop_decimals():
    """What the comparison keeps: 62 gouges are not 61, 6.81 s is 9.07 s."""
    same = readme.normalised(["gouge 62  time 6.81 s", "\u2501\u2501\u2501 x"])
    assert same == readme.normalised(["gouge 62 time 9.07 s", "\u2501 x"])
    assert same != readme.normalised(["gouge 61 time 6.81 s", "\u2501 x"])


@pytest.fixture(scope="module")
def outcomes(tmp_path_factory, realdata):
    """Every block run once, in the page's order (later blocks use what earlier ones wrote,
    as a reader following the page does), with its own results store."""
    env = readme.environment(tmp_path_factory.mktemp("readme") / "results.sqlite")
    return {b.name: readme.run_block(b, env) for b in BLOCKS}


@pytest.mark.slow
@pytest.mark.timeout(1800)  # the first block's setup runs every block (a few minutes on 2 cores)
@pytest.mark.parametrize("block", BLOCKS, ids=[b.name for b in BLOCKS])
def test_block_runs_as_written(block, outcomes):
    problems = [p for o in outcomes[block.name] if (p := o.problem(block.kind))]
    assert not problems, "\n\n".join(problems)
