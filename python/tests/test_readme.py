"""The README's Python example runs as written (from the repository root)."""

import re

from conftest import REPO


def test_readme_example_runs(monkeypatch, capsys):
    text = (REPO / "README.md").read_text(encoding="utf-8")
    section = text[text.index("\n## Python\n") :]
    block = re.search(r"```python\n(.*?)```", section, re.S).group(1)
    monkeypatch.chdir(REPO)
    exec(compile(block, "README.md", "exec"), {})
    printed = capsys.readouterr().out
    assert "[[" in printed  # the matrices were printed
