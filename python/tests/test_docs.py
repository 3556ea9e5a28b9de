"""The Python examples of docs/python.md run and their assertions hold."""

import pathlib
import re

import pytest

DOC = pathlib.Path(__file__).resolve().parents[2] / "docs" / "python.md"
BLOCKS = re.findall(r"```python\n(.*?)```", DOC.read_text(encoding="utf-8"), re.S) if DOC.exists() else []


def test_the_doc_has_examples():
    assert len(BLOCKS) >= 2


@pytest.mark.parametrize("code", BLOCKS, ids=[f"block{i}" for i in range(len(BLOCKS))])
def test_doc_example(code):
    if "import distributed" in code:
        pytest.importorskip("distributed")  # the Dask example needs reckon[dask]
    exec(compile(code, str(DOC), "exec"), {})
