"""The README's Python quick start runs as written."""

import os
import re

from conftest import ROOT


def test_the_readme_quick_start_runs(tmp_path, capsys):
    text = (ROOT / "README.md").read_text()
    section = text.split("## Python", 1)[1].split("\n## ", 1)[0]
    blocks = re.findall(r"```python\n(.*?)```", section, re.S)
    assert blocks, "the README has a Python quick start"
    here = os.getcwd()
    os.chdir(ROOT)
    try:
        for code in blocks:
            exec(compile(code, "README.md", "exec"), {"__name__": "readme"})
    finally:
        os.chdir(here)
    assert "period" in capsys.readouterr().out
