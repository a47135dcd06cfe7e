"""The README's snippets cannot rot: its Python blocks run here, its C++ block is the
consumer program that ctest builds against the installed package."""
import re

from shared_cases import REPO, SHARED

README = (REPO / "README.md").read_text()


def blocks(language):
    return re.findall(rf"^```{language}\n(.*?)^```$", README, flags=re.S | re.M)


def test_python_blocks_run(tmp_path, monkeypatch):
    # The snippets use ../shared relative to a checkout, and write files next to it.
    (tmp_path / "shared").symlink_to(SHARED.resolve())
    (tmp_path / "checkout").mkdir()
    monkeypatch.chdir(tmp_path / "checkout")
    snippets = blocks("python")
    assert len(snippets) >= 2
    namespace = {}
    for code in snippets:
        exec(compile(code, "README.md", "exec"), namespace)


def test_cpp_block_is_the_consumer_program():
    cpp = blocks("cpp")
    assert len(cpp) == 1
    assert cpp[0] == (REPO / "tests" / "cpp" / "consumer" / "main.cpp").read_text()
