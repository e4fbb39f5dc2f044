"""The dispatcher's exit codes (issue 19: no command is an error, not a success)."""

from feedopt.cli import main


def test_no_command_prints_help_and_exits_2(capsys) -> None:
    assert main([]) == 2
    err = capsys.readouterr().err
    assert "usage: feedopt" in err and "give a command" in err
    for command in ("run", "validate", "compare", "path", "forces", "calibrate", "robot"):
        assert command in err


def test_signal_handlers_are_restored_after_a_command(tmp_path) -> None:
    import signal

    before = signal.getsignal(signal.SIGTERM)
    assert main(["validate", "--schema"]) == 0
    assert signal.getsignal(signal.SIGTERM) is before
