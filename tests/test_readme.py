"""The examples in the READMEs are what the code really does: every `>>>` block is a doctest."""

import doctest
import re

import pytest

from conftest import ROOT

READMES = ["README.md", "host/README.md", "hil_sim/README.md", "firmware/README.md", "protocol/PROTOCOL.md"]


def doctest_blocks(text: str) -> list[str]:
    return [block for block in re.findall(r"```python\n(.*?)```", text, re.S) if ">>>" in block]


@pytest.mark.parametrize("name", READMES)
def test_readme_examples_run_as_shown(name):
    text = (ROOT / name).read_text()
    parser, runner = doctest.DocTestParser(), doctest.DocTestRunner(optionflags=doctest.ELLIPSIS)
    for i, block in enumerate(doctest_blocks(text)):
        runner.run(parser.get_doctest(block, {}, f"{name}[{i}]", name, 0))
    assert runner.failures == 0, f"{runner.failures} example(s) in {name} do not match the code (see output)"


def test_the_main_readme_has_a_checked_example():
    assert doctest_blocks((ROOT / "README.md").read_text())
