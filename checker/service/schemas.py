"""The published JSON Schemas of the service protocol (draft 2020-12), generated from its
pydantic models: `service-request.schema.json` (every request, by `op`) and
`service-reply.schema.json` (every reply: one per op, or the error reply), in
`checker/resources/schemas/`. Regenerate with `python -m checker.service.schemas`."""

from __future__ import annotations

import json
import sys
from pathlib import Path

from pydantic import TypeAdapter

from checker.service.protocol import PROTOCOL_VERSION, REQUEST
from checker.service.replies import REPLY

ID_BASE = "https://pathcheck.invalid/schemas"


def _published(adapter: TypeAdapter, name: str, title: str) -> dict:
    schema = adapter.json_schema()
    schema["$schema"] = "https://json-schema.org/draft/2020-12/schema"
    schema["$id"] = f"{ID_BASE}/service-{name}-v{PROTOCOL_VERSION}.json"
    schema["title"] = title
    return schema


def json_schemas() -> dict[str, dict]:
    """File name -> schema, for every message of the protocol."""
    return {
        "service-request.schema.json": _published(
            REQUEST, "request", f"pathcheck service request, protocol {PROTOCOL_VERSION}"),
        "service-reply.schema.json": _published(
            REPLY, "reply", f"pathcheck service reply, protocol {PROTOCOL_VERSION}"),
    }


def write_schemas(folder: Path) -> list[Path]:
    """Write every schema into `folder` (sorted keys, 2-space indent); the paths written."""
    written = []
    for name, schema in json_schemas().items():
        path = folder / name
        path.write_text(json.dumps(schema, indent=2, sort_keys=True) + "\n")
        written.append(path)
    return written


if __name__ == "__main__":
    from checker.resources import resource

    target = Path(sys.argv[1]) if len(sys.argv) > 1 else resource("schemas")
    for written in write_schemas(Path(target)):
        print(written)
