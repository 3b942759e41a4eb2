"""The README's example runs as written."""

import re
from pathlib import Path

README = Path(__file__).resolve().parents[2] / "README.md"


def test_readme_example_runs(capsys):
    blocks = re.findall(r"```python\n(.*?)```", README.read_text(), flags=re.S)
    assert blocks, "README.md has no python example"
    exec(compile(blocks[0], "README.md", "exec"), {})
    out = capsys.readouterr().out
    assert "error" in out and "Casimirs" in out


def test_readme_has_exactly_the_two_ci_commands():
    text = README.read_text()
    assert text.count("<!-- ci:install -->") == 1 and text.count("<!-- ci:test -->") == 1
