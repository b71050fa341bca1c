"""The one TOML + pydantic loader (`checker/toml_load.py`) as the config, the machines and the
tool library see it: every bad file is one line naming the file and what was expected."""

from __future__ import annotations

import pytest

from checker.config import load_config
from checker.errors import PathcheckError
from checker.postproc.machine import load_machine_file
from checker.tool_library import load_tool_library

LOADERS = [(load_config, "config file", "config"), (load_machine_file, "machine file", "machine"),
           (load_tool_library, "tool library", "tools")]


def _error(load, path) -> PathcheckError:
    with pytest.raises(PathcheckError) as err:
        load(path)
    assert "\n" not in str(err.value) and str(err.value).startswith(f"{path}: ")
    return err.value


@pytest.mark.parametrize(("load", "what", "code"), LOADERS)
def test_unreadable_files_name_the_file(tmp_path, load, what, code):
    err = _error(load, tmp_path / "none.toml")
    assert err.message == f"{what} not found" and err.code == code
    assert _error(load, tmp_path).message.startswith(f"cannot read {what}: ")  # a folder
    bad = tmp_path / "bad.toml"
    bad.write_text('name = "x"\n\nfield = \n')
    assert _error(load, bad).message.startswith(f"{what} is not valid TOML: ")
    assert "line 3" in _error(load, bad).message
    bad.write_bytes(b'name = "\xff"\n')
    assert _error(load, bad).message.startswith(f"{what} is not valid TOML: ")


def test_config_field_is_named_with_the_value_found(tmp_path):
    user = tmp_path / "user.toml"
    user.write_text("[check]\ntolerance = -1\n")
    assert _error(load_config, user).message == (
        "config field 'check.tolerance': Input should be greater than or equal to 0, found -1")
    user.write_text("[check]\nspeed = 3\n")
    assert _error(load_config, user).message == (
        "config field 'check.speed': Extra inputs are not permitted, found 3")
    user.write_text("[check]\ntolerance = 0.002\n")
    assert load_config(user).check.tolerance == 0.002
