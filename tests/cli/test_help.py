"""Every option of every subcommand says what it does and shows its default."""

import argparse

from game.cli import arguments


def test_every_option_has_a_help_line_and_shows_its_default():
    parser = arguments.build_parser()
    subparsers = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    missing = []
    for name, sub in subparsers.choices.items():
        formatter = sub._get_formatter()
        for action in sub._actions:
            if isinstance(action, argparse._HelpAction) or not action.option_strings:
                continue
            flag = f"{name} {action.option_strings[-1]}"
            if not action.help:
                missing.append(f"{flag}: no help")
                continue
            shown = formatter._expand_help(action)
            if (action.default not in (None, False, argparse.SUPPRESS)
                    and "default" not in shown):
                missing.append(f"{flag}: default {action.default!r} not shown")
    assert not missing, "\n".join(missing)


def test_the_debug_views_are_each_explained():
    sub = next(a for a in arguments.build_parser()._actions
               if isinstance(a, argparse._SubParsersAction))
    text = sub.choices["capture"].format_help()
    for view in ("map:", "map-count:", "cache:", "shadowed-lights:"):
        assert view in " ".join(text.split()), view
