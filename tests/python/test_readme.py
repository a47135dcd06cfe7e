"""The README's snippets cannot rot: they run here in a copy of the repository's tracked
example files with nothing beside it (as in a fresh clone), its `mpmpp` commands run through
the command line, and its C++ block is the consumer program that ctest builds against the
installed package."""
import re
import shlex
import shutil

from mpmpp import cli

from example_cases import EXAMPLES, REPO

README = (REPO / "README.md").read_text()


def blocks(language):
    return re.findall(rf"^```{language}\n(.*?)^```$", README, flags=re.S | re.M)


def clone_like_copy(tmp_path, monkeypatch):
    """A folder holding what a clone holds for the snippets (README, examples/) and nothing
    beside it; the working directory for the snippets."""
    clone = tmp_path / "clone"
    clone.mkdir()
    shutil.copy(REPO / "README.md", clone)
    shutil.copytree(EXAMPLES, clone / "examples")
    assert [p.name for p in tmp_path.iterdir()] == ["clone"]
    monkeypatch.chdir(clone)
    return clone


def test_python_blocks_run(tmp_path, monkeypatch):
    clone_like_copy(tmp_path, monkeypatch)
    snippets = blocks("python")
    assert len(snippets) >= 2
    namespace = {}
    for code in snippets:
        exec(compile(code, "README.md", "exec"), namespace)


def test_shell_commands_run(tmp_path, monkeypatch, capsys):
    clone = clone_like_copy(tmp_path, monkeypatch)
    commands = [line for block in blocks("sh") for line in block.splitlines() if line.strip()]
    assert len(commands) >= 3
    for line in commands:
        argv = shlex.split(line)
        assert argv[0] == "mpmpp", f"README sh block runs something other than mpmpp: {line}"
        assert cli.main(argv[1:]) == 0, f"{line}\n{capsys.readouterr().err}"
    assert (clone / "out" / "model_updated.json").is_file()


def test_cpp_block_is_the_consumer_program():
    cpp = blocks("cpp")
    assert len(cpp) == 1
    assert cpp[0] == (REPO / "tests" / "cpp" / "consumer" / "main.cpp").read_text()
