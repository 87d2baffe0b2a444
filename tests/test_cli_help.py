"""`dentdemo --help` and every command's --help show each option's default and one example."""

from __future__ import annotations

import pytest

from dentdemo.cli import COMMANDS, build_parser, main


def _help(capsys, *argv: str) -> str:
    with pytest.raises(SystemExit) as done:
        main([*argv, "--help"])
    assert done.value.code == 0
    return capsys.readouterr().out


def test_top_level_help_lists_every_command_with_examples(capsys):
    text = _help(capsys)
    for module in COMMANDS:
        name = module.__name__.rsplit(".", 1)[-1]
        assert f"    {name} " in text, name
    assert "examples:" in text and "dentdemo render" in text


@pytest.mark.parametrize("name", [m.__name__.rsplit(".", 1)[-1] for m in COMMANDS])
def test_every_command_help_has_defaults_and_an_example(capsys, name):
    text = _help(capsys, name)
    assert f"example:\n  dentdemo {name} " in text
    parser = build_parser()
    sub = next(a for a in parser._actions if a.dest == "command").choices[name]
    for action in sub._actions:
        default = action.default
        shown = default not in (None, False, [], "==SUPPRESS==") and action.option_strings
        if shown and action.help != "==SUPPRESS==":
            # compared without whitespace: argparse wraps a long path at its hyphens
            wanted = "".join(f"(default: {default})".split())
            assert wanted in "".join(text.split()), (name, action.dest)
