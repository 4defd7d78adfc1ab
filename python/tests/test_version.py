"""The package's version is the command's, and both are the one CMakeLists.txt sets."""

import re

import stickslip

from conftest import SOURCE_DIR, cli


def test_version_is_the_commands_and_the_projects():
    done = cli("--version")
    match = re.fullmatch(r"stickslip (\S+) \(git commit (\S+)\)\n", done.stdout)
    assert match, done.stdout
    assert stickslip.__version__ == match.group(1)
    assert stickslip.git_commit == match.group(2)
    project = re.search(r"project\(stickslip VERSION (\S+) ", (SOURCE_DIR / "CMakeLists.txt").read_text())
    assert stickslip.__version__ == project.group(1)
