"""The vendored three.js (`make setup` copies it from tools/three/node_modules into
checker/resources/vendor/three/, pinned by tools/three/package-lock.json): its modules' text,
version and licence, to be inlined into the view page."""

from __future__ import annotations

from dataclasses import dataclass
from importlib import resources

from checker.errors import PathcheckError

MODULES = ("three.core.js", "three.module.js", "OrbitControls.js")


@dataclass(frozen=True)
class Three:
    """three.js's module sources (name -> text), its version and its licence text."""

    modules: dict[str, str]
    version: str
    licence: str


def vendored_three() -> Three:
    """The vendored three.js; PathcheckError (usage) naming `make setup` when it is missing."""
    folder = resources.files("checker.resources").joinpath("vendor", "three")
    try:
        modules = {name: folder.joinpath(name).read_text(encoding="utf-8") for name in MODULES}
        version = folder.joinpath("VERSION").read_text(encoding="utf-8").strip()
        licence = folder.joinpath("LICENSE").read_text(encoding="utf-8")
    except OSError as err:
        raise PathcheckError(f"three.js is not vendored ({err.strerror or err}): expected "
                             "checker/resources/vendor/three/ from `make setup` (npm ci in "
                             "tools/three)", code="usage") from err
    return Three(modules, version, licence)
