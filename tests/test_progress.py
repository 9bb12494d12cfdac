import io
import os
import subprocess
import sys

import pytest

from flowvo import progress as progress_module
from flowvo.cli import main
from flowvo.progress import progress


class FakeTerminal(io.StringIO):
    def isatty(self) -> bool:
        return True


@pytest.mark.parametrize("stream, enabled, drawn", [
    (FakeTerminal(), True, True),
    (io.StringIO(), True, False),  # stderr redirected to a file or a pipe: no bar
    (FakeTerminal(), False, False),  # -q or FLOWVO_PROGRESS=0 wins even on a terminal
])
def test_bar_is_drawn_only_on_a_terminal_and_when_enabled(monkeypatch, stream, enabled, drawn):
    monkeypatch.setattr(sys, "stderr", stream)
    monkeypatch.setattr(progress_module, "_enabled", enabled)
    assert list(progress(range(3), "counting", 3)) == [0, 1, 2]
    assert ("counting" in stream.getvalue()) == drawn


@pytest.mark.parametrize("setting, drawn", [("0", False), ("1", True)])
def test_environment_variable_switches_bars_off(setting, drawn):
    code = ("import io, sys\n"
            "class T(io.StringIO):\n    def isatty(self): return True\n"
            "sys.stderr = T()\n"
            "from flowvo.progress import progress\n"
            "list(progress(range(3), 'counting', 3))\n"
            "sys.stdout.write(sys.stderr.getvalue())\n")
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True,
                            env={**os.environ, "FLOWVO_PROGRESS": setting})
    assert ("counting" in result.stdout) == drawn


@pytest.mark.parametrize("flag_position", [0, 1])
def test_quiet_flag_switches_bars_off(monkeypatch, tmp_path, flag_position):
    monkeypatch.setattr(progress_module, "_enabled", True)
    args = ["eval", "--gt", str(tmp_path / "absent.txt"), "--pred", str(tmp_path / "absent.txt")]
    args.insert(flag_position, "-q")
    main(args)
    assert progress_module._enabled is False


def test_a_silent_iteration_makes_no_lock_between_processes():
    """tqdm's first bar creates a named semaphore; a batch worker ended while creating it leaves it behind."""
    code = ("from tqdm import tqdm\n"
            "from flowvo.progress import progress\n"
            "assert list(progress(range(3), 'counting', 3)) == [0, 1, 2]\n"
            "print(hasattr(tqdm, '_lock'))\n")
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True,
                            env={**os.environ, "FLOWVO_PROGRESS": "0"})
    assert result.stdout.strip() == "False"
