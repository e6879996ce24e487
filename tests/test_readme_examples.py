"""Every ```python block of README.md runs as written.

Each block runs on its own (a fresh namespace, so a block states its own imports and data) in a
temporary working folder, so files it writes land there. A block that needs something a user of
a fresh clone would not have starts with a comment ``# needs: <what>``; it is skipped with that
reason, and the README text around it says so.
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest

README = Path(__file__).resolve().parents[1] / "README.md"
BLOCK = re.compile(r"^```python[ \t]*\n(.*?)^```[ \t]*$", re.MULTILINE | re.DOTALL)
NEEDS = re.compile(r"\A#\s*needs:\s*(.+)")


def python_blocks(text: str) -> list[tuple[int, str]]:
    """``(line number, code)`` of every ```python block of ``text``, in order."""
    return [(text.count("\n", 0, match.start()) + 1, match.group(1)) for match in BLOCK.finditer(text)]


BLOCKS = python_blocks(README.read_text(encoding="utf-8"))


def test_the_readme_has_python_examples_and_the_extraction_finds_them():
    sample = "text\n```python\nx = 1\n```\n```bash\nls\n```\n```python\n# needs: a robot\ny = 2\n```\n"
    assert python_blocks(sample) == [(2, "x = 1\n"), (8, "# needs: a robot\ny = 2\n")]
    assert len(BLOCKS) >= 4


@pytest.mark.parametrize("line, code", BLOCKS, ids=[f"README.md:{line}" for line, _ in BLOCKS])
def test_readme_block_runs(line, code, tmp_path, monkeypatch):
    needs = NEEDS.match(code.lstrip())
    if needs:
        pytest.skip(f"README.md line {line} needs {needs.group(1).strip()}")
    monkeypatch.chdir(tmp_path)
    exec(compile(code, f"README.md:{line}", "exec"), {"__name__": "__readme__"})
