"""The CLI run in-process for the tests: ``cli.main(argv)`` and the check of its one-line errors."""

from __future__ import annotations

from kinserve.service import cli


def run_main(argv: list[str], capsys) -> tuple[int, str, str]:
    """``(exit code, stdout, stderr)`` of ``kinserve <argv>`` run in this process (argparse's exit
    included)."""
    try:
        code = cli.main(argv)
    except SystemExit as exc:  # argparse
        code = exc.code
    out = capsys.readouterr()
    return code, out.out, out.err


def assert_one_line_error(code, out, err, needle=None) -> None:
    """Exit code 2, no traceback, one line on stderr starting ``error: `` (and holding ``needle``)."""
    assert code == 2, (code, out, err)
    assert "Traceback" not in out + err
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: "), err
    if needle:
        assert needle in err, err
