"""`cmake --install build --prefix P` gives P/bin/stickslip and a module that finds it."""

import os
import subprocess
import sys

import pytest

from conftest import SOURCE_DIR


def test_the_installed_module_imports_and_finds_the_installed_command(tmp_path):
    build = os.environ.get("STICKSLIP_BUILD_DIR", str(SOURCE_DIR / "build"))
    cmake = os.environ.get("CMAKE_COMMAND", "cmake")
    prefix = tmp_path / "prefix"
    subprocess.run([cmake, "--install", build, "--prefix", prefix], check=True, capture_output=True)
    assert (prefix / "bin" / "stickslip").is_file()
    site = prefix / "lib" / f"python{sys.version_info.major}.{sys.version_info.minor}" / "dist-packages"
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "STICKSLIP_EXECUTABLE")}
    env["PYTHONPATH"] = str(site)
    env["PATH"] = "/usr/bin:/bin"  # no other stickslip to fall back on
    done = subprocess.run(
        [sys.executable, "-c", "import stickslip, stickslip._sweep as s; print(stickslip.__file__); "
         "print(s.executable()); print(stickslip.Case.from_dict({}).to_dict()['lattice']['nx'])"],
        env=env, cwd=tmp_path, capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    module, executable, nx = done.stdout.split()
    assert module.startswith(str(site))
    assert executable == str(prefix / "bin" / "stickslip")
    assert nx == "15"
