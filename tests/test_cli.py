"""Command line, run in-process through main()."""

import pytest

from frictionid.cli import main


def test_demo_runs_the_block_reference_test(capsys):
    assert main(["demo", "--block", "--mesh-size", "2.5"]) == 0
    out = capsys.readouterr().out
    assert "reference test 1" in out
    for zone in "ABCD":
        assert f"\n{zone} " in out
    assert "block_top.y" in out and "d/dA" in out


def test_bad_input_exits_2_with_a_message_and_no_traceback(capsys):
    assert main(["demo", "--block", "--mesh-size", "-1"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("frictionid: error:") and "mesh_size" in err and "Traceback" not in err


def test_unknown_command_is_a_usage_error():
    with pytest.raises(SystemExit) as exit_info:
        main(["frobnicate"])
    assert exit_info.value.code == 2
