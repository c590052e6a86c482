"""The README's Python example runs as written and says what it claims."""

import re
from pathlib import Path

README = Path(__file__).parent.parent / "README.md"


def test_python_api_example_runs(capsys):
    section = README.read_text().split("## Python API", 1)[1]
    code = re.search(r"```python\n(.*?)```", section, re.S).group(1)
    namespace: dict = {}
    exec(compile(code, "README.md (Python API)", "exec"), namespace)
    result, steel = namespace["result"], namespace["steel"]
    assert result.converged
    assert abs(steel["E1_GPa"] - 201.0) < 3 * steel["std"]["E1_GPa"], "Table 1: steel E1 = 201 GPa"
    out = capsys.readouterr().out
    assert "brass_top" in out and "converged" in out and "condition number" in out
