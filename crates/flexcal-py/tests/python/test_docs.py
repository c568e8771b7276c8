"""Every ```python example of docs/python.md runs, in order, in one
namespace, in a folder holding what the page says it holds: the IPA UR10
series (Series_B/, Series_C/), the UR10 URDF of the shared robots
(ur10_robot.urdf) and the repository's crates/ (linked, never copied). An
example that needs data absent here is skipped with the reason, as are the
examples that use what it would have defined."""

import os
import pathlib
import re

import pytest
from conftest import IPA, REPOSITORY

DOC = REPOSITORY / "docs" / "python.md"
URDF = REPOSITORY.parent / "shared" / "robots" / "urdf" / "ur10_robot.urdf"
BLOCKS = re.findall(r"```python\n(.*?)```", DOC.read_text(), flags=re.S)


def test_the_page_has_its_examples():
    assert len(BLOCKS) >= 5, f"{len(BLOCKS)} python blocks found in {DOC}"


@pytest.fixture(scope="module")
def session(tmp_path_factory):
    folder = tmp_path_factory.mktemp("python-doc")
    (folder / "crates").symlink_to(REPOSITORY / "crates")
    for series in ["Series_B", "Series_C"]:
        if (IPA / series).exists():
            (folder / series).symlink_to(IPA / series)
    if URDF.exists():
        (folder / URDF.name).symlink_to(URDF)
    return {"folder": folder, "namespace": {}, "skipped": []}


def missing_input(code, folder):
    """The file an example reads that this machine lacks, if any."""
    code = re.sub(r"(^|\s)#.*", "", code, flags=re.M)  # comments name files too
    for name in re.findall(r'"((?:Series_[BC]/)?[\w./-]+\.(?:csv|urdf))"', code):
        if not (folder / name).exists():
            return name
    return None


@pytest.mark.parametrize("index", range(len(BLOCKS)))
def test_example_runs(session, index):
    code = BLOCKS[index]
    first_line = code.strip().splitlines()[0]
    absent = missing_input(code, session["folder"])
    if absent:
        session["skipped"].append(index)
        # Its imports still serve the examples below that need no data.
        imports = [l for l in code.splitlines() if re.match(r"(import|from) \w", l)]
        exec("\n".join(imports), session["namespace"])
        pytest.skip(f"docs/python.md example {index + 1} ({first_line!r}): {absent} absent here")
    cwd = os.getcwd()
    os.chdir(session["folder"])
    try:
        exec(compile(code, f"docs/python.md example {index + 1}", "exec"), session["namespace"])
    except NameError as error:
        if not session["skipped"]:
            raise
        pytest.skip(f"example {index + 1} uses what a skipped example defines: {error}")
    finally:
        os.chdir(cwd)
