"""The README's "From Python" examples, run as they are printed."""

import os
import re
import shutil
import subprocess
import sys

README = os.path.join(os.path.dirname(__file__), "..", "..", "..", "README.md")


def examples():
    text = open(README, encoding="utf-8").read()
    section = text.split("## From Python", 1)[1].split("\n## ", 1)[0]
    return re.findall(r"```python\n(.*?)```", section, re.S)


def test_the_readme_has_two_ten_line_examples():
    blocks = examples()
    assert len(blocks) == 2
    for block in blocks:
        assert len(block.strip().splitlines()) <= 10


def test_the_readme_examples_pass(tmp_path):
    for i, block in enumerate(examples()):
        (tmp_path / f"test_readme_{i}.py").write_text(block)
    for helper in ("conftest.py", "peers.py"):
        shutil.copy(os.path.join(os.path.dirname(__file__), helper), tmp_path)
    done = subprocess.run(
        [sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", str(tmp_path)],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert done.returncode == 0, done.stdout + done.stderr
    assert "2 passed" in done.stdout, done.stdout
