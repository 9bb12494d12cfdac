"""Helpers of the hostile-input suite (tests/test_hostile_*.py): run the CLI in-process and check that a
failure is exactly one line on stderr naming what is wrong, with no traceback; start it as a process that
Ctrl-C interrupts (the signal tests, and the batch's)."""

from __future__ import annotations

import hashlib
import signal
import subprocess
from pathlib import Path

from flowvo.cli import main


def interruptible(args: list[str], env: dict[str, str]) -> subprocess.Popen:
    """``args`` started with pipes for stdout and stderr, as a process that Ctrl-C (SIGINT) interrupts even
    where this one ignores SIGINT (pytest run as a background job inherits it ignored, and a Python child
    then never raises KeyboardInterrupt: it ran to the end and exited 0)."""
    return subprocess.Popen(args, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env,
                            preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))


def cli(capsys, *args: object) -> tuple[int, str, str]:
    """Exit code, stdout and stderr of ``flowvo ARGS`` (SystemExit from argparse becomes its code)."""
    capsys.readouterr()
    try:
        code = main([str(a) for a in args] + ["-q"])
    except SystemExit as exit_:
        code = exit_.code
    captured = capsys.readouterr()
    return code, captured.out, captured.err


def refused(capsys, *args: object, says: str | tuple[str, ...]) -> str:
    """Run ``flowvo ARGS``, assert exit 2 with one stderr line containing every ``says``; returns it."""
    code, _, err = cli(capsys, *args)
    assert code == 2, err
    assert err.count("\n") == 1 and "Traceback" not in err, err
    for text in (says,) if isinstance(says, str) else says:
        assert text in err, err
    return err


def tree_digest(root: Path) -> str:
    """SHA-256 over every path below ``root`` and its content: equal digests mean nothing was written."""
    digest = hashlib.sha256()
    for path in sorted(root.rglob("*")):
        digest.update(str(path.relative_to(root)).encode())
        if path.is_file():
            digest.update(path.read_bytes())
    return digest.hexdigest()
