"""The view page: the scene (`checker.view.scene`) as JSON, three.js (`checker.view.vendor`) and
the page's script (checker/resources/templates/view.js) inlined into
checker/resources/templates/view.html.j2, so that the file opens offline from a file:// URL and
loads nothing."""

from __future__ import annotations

import json
import re
from importlib import resources
from pathlib import Path

from checker.atomic import write_file
from checker.errors import PathcheckError
from checker.results import ResultsDocument
from checker.verdict import FINDINGS
from checker.view.scene import build_view
from checker.view.vendor import vendored_three

# text that would end or re-open a script element's raw text early
_UNSAFE = re.compile(r"</script|<!--|<script", re.IGNORECASE)


def _inline(name: str, text: str) -> str:
    """`text` to go inside a <script> element as is; PathcheckError when it cannot."""
    if _UNSAFE.search(text):
        raise PathcheckError(f"{name} cannot be inlined: it holds '</script', '<script' or '<!--'",
                             code="usage")
    return text


def render_page(doc: ResultsDocument, scene: dict) -> str:
    """The page's HTML text for `scene` of the job `doc`."""
    from jinja2 import Environment, FileSystemLoader, StrictUndefined

    three = vendored_three()
    templates = resources.files("checker.resources").joinpath("templates")
    view_js = templates.joinpath("view.js").read_text(encoding="utf-8")
    modules = [("three.core", three.modules["three.core.js"]),
               ("three", three.modules["three.module.js"]),
               ("OrbitControls", three.modules["OrbitControls.js"]), ("view", view_js)]
    env = Environment(loader=FileSystemLoader(str(templates)), autoescape=True,
                      undefined=StrictUndefined)
    c = doc.summary.counts
    found = ", ".join(f"{getattr(c, v)} {v}" for v in FINDINGS if getattr(c, v))
    meta = (f"{doc.job.axis_class}, {doc.summary.points} poses, {doc.summary.status}"
            + (f": {found}" if found else "") + f"; cutter {doc.job.cutter}")
    return env.get_template("view.html.j2").render(
        title=doc.job.path, meta=meta, three_version=three.version,
        three_licence=three.licence,
        scene_json=json.dumps(scene, separators=(",", ":")).replace("<", "\\u003c"),
        modules=[(name, _inline(name, text)) for name, text in modules])


def write_view(path: str | Path, doc: ResultsDocument, **scene_options) -> Path:
    """Write the view of the checked job `doc` to `path` (atomically): `build_view(doc,
    **scene_options)` in the page. The path written."""
    scene = build_view(doc, **scene_options)
    return write_file(path, render_page(doc, scene), what="3-D view")
