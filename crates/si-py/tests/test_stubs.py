"""The type stubs (`__init__.pyi`, `aio.pyi`) match the installed module: mypy's stubtest,
with the justified entries of `stubtest-allowlist.txt` next to this crate's pyproject.toml.

Outside CI a missing mypy skips this test; in CI (CI set) it fails it."""

import os
import subprocess
import sys

import pytest

ALLOWLIST = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "stubtest-allowlist.txt")


def test_stubs_match_the_runtime(tmp_path):
    try:
        import mypy  # noqa: F401
    except ImportError:
        if os.environ.get("CI"):
            pytest.fail("mypy is missing (CI installs it)")
        pytest.skip("mypy is not installed")
    # From an empty directory, so the installed package is what is checked.
    run = subprocess.run(
        [sys.executable, "-m", "mypy.stubtest", "si_serial", "--allowlist", ALLOWLIST],
        cwd=tmp_path, capture_output=True, text=True, timeout=120,
    )
    assert run.returncode == 0, run.stdout + run.stderr
