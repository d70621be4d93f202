"""The suite's own rules: under xdist (`make test`), the tests marked realtime run one at a time on
one worker, whichever files they are in, while the others spread over every worker."""

import re
import shutil
import subprocess
import sys

from conftest import ROOT

REALTIME = '''import time
import pytest

pytestmark = pytest.mark.realtime


@pytest.mark.parametrize("i", range(4))
def test_keeps_to_the_clock(i):
    time.sleep(0.2)
'''
PLAIN = '''import time
import pytest


@pytest.mark.parametrize("i", range(8))
def test_anything(i):
    time.sleep(0.2)
'''


def test_realtime_tests_share_one_worker_and_the_rest_spread(tmp_path):
    shutil.copy(ROOT / "tests" / "conftest.py", tmp_path / "conftest.py")
    (tmp_path / "test_clock_a.py").write_text(REALTIME)
    (tmp_path / "test_clock_b.py").write_text(REALTIME)
    (tmp_path / "test_plain.py").write_text(PLAIN)
    run = subprocess.run([sys.executable, "-m", "pytest", "-n", "2", "--dist", "loadgroup", "-v", "-p", "no:cacheprovider",
                          "-W", "ignore::pytest.PytestUnknownMarkWarning", str(tmp_path)],
                         cwd=tmp_path, capture_output=True, text=True, timeout=120)
    assert run.returncode == 0, run.stdout[-2000:] + run.stderr[-2000:]
    ran = re.findall(r"\[(gw\d)\] .*PASSED \S*(test_\w+)\.py::", run.stdout)
    clock = {worker for worker, module in ran if module.startswith("test_clock")}
    assert len(ran) == 16 and len(clock) == 1, ran
    assert {worker for worker, _ in ran} == {"gw0", "gw1"}, ran
