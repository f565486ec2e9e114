"""Shared fixtures of the Python module's tests: the CLI binary the module is compared against.

Run by CTest (tests/python/CMakeLists.txt sets PYTHONPATH and POLYDEM_CLI), or by hand:
  PYTHONPATH=build/python POLYDEM_CLI=build/apps/polydem /usr/bin/python3 -m pytest tests/python
"""
import os
import re
import subprocess

import pytest


@pytest.fixture(scope="session")
def cli():
    """Run `polydem ARGS...` in a directory; returns the CompletedProcess (text)."""
    path = os.environ.get("POLYDEM_CLI")
    if not path or not os.path.exists(path):
        pytest.skip("POLYDEM_CLI does not name the polydem binary")
    path = os.path.abspath(path)

    def run(*args, cwd=None, check=True):
        result = subprocess.run([path, *map(str, args)], cwd=cwd, capture_output=True, text=True, timeout=600)
        if check and result.returncode != 0:
            raise AssertionError(f"polydem {' '.join(map(str, args))} exited {result.returncode}:\n"
                                 f"{result.stdout}\n{result.stderr}")
        return result

    return run


def field(text, pattern):
    """The first group of `pattern` in the CLI's output (the test fails if it is missing)."""
    match = re.search(pattern, text, re.MULTILINE)
    assert match, f"'{pattern}' not in:\n{text}"
    return match.group(1)
