"""Robot commands: the written forms users type and the errors they get."""

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from siftom.errors import CommandParseError
from siftom.world.commands import VERBS, RobotCommand


@pytest.mark.parametrize(
    ("text", "expected"),
    [
        ("deliver(fork,3)", RobotCommand("deliver", "fork", 3)),
        ("fetch(cereal)", RobotCommand("fetch", "cereal", 1)),
        ("  Deliver ( Wine_Glass , 2 ) ", RobotCommand("deliver", "wine_glass", 2)),
        ("fetch(orange_juice,1)", RobotCommand("fetch", "orange_juice", 1)),
        ("deliver(plate)", RobotCommand("deliver", "plate", 1)),
    ],
)
def test_parse_valid_forms(text, expected):
    assert RobotCommand.parse(text) == expected


def test_str_is_the_canonical_form():
    assert str(RobotCommand("fetch", "cereal")) == "fetch(cereal)"
    assert str(RobotCommand("fetch", "cereal", 2)) == "fetch(cereal,2)"
    assert str(RobotCommand("deliver", "fork", 1)) == "deliver(fork,1)"


@pytest.mark.parametrize(
    "text",
    ["", "fork", "deliver fork 3", "deliver(fork,0)", "deliver(fork,-1)", "bring(fork,3)", "deliver(3,fork)",
     "deliver(fork,3", "deliver(fork,3,4)", "deliver()", "deliver(fork, three)"],
)
def test_parse_invalid_forms_lists_the_valid_forms(text):
    with pytest.raises(CommandParseError, match="valid forms: deliver\\(CLASS,COUNT\\)"):
        RobotCommand.parse(text)


def test_parse_rejects_non_strings():
    with pytest.raises(CommandParseError, match="must be a string"):
        RobotCommand.parse(3)  # type: ignore[arg-type]


def test_constructor_validates():
    with pytest.raises(CommandParseError, match="unknown verb"):
        RobotCommand("throw", "fork")
    with pytest.raises(CommandParseError, match="count must be >= 1"):
        RobotCommand("deliver", "fork", 0)


classes = st.from_regex(r"[a-z_][a-z0-9_]{0,15}", fullmatch=True)


@settings(deadline=None)  # timing-free: a loaded machine must not fail it
@given(verb=st.sampled_from(VERBS), cls=classes, count=st.integers(1, 10_000))
def test_parse_inverts_str(verb, cls, count):
    cmd = RobotCommand(verb, cls, count)
    assert RobotCommand.parse(str(cmd)) == cmd
