"""Checking controllability without the command line; bad options named."""

from __future__ import annotations

import pytest

from stratcli import api
from stratcli.errors import InputError


def test_check_a_preset_at_a_configuration_and_name_the_option_when_it_is_bad():
    report = api.check_controllability("one-arm", at="0, pi/3, 0, 0", samples=3)
    assert report.controllable and report.document["target"] == "one-arm"
    with pytest.raises(InputError, match=r"^at: needs 4 values"):
        api.check_controllability("one-arm", at="0, 1", samples=3)
