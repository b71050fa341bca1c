"""CURVE keys for the service (ZeroMQ's CurveZMQ, clients checked by a ZAP handler): one key
folder holds the server's key pair, a client's key pair and the public keys of the clients
the server lets in.

    DIR/server.key           server public key (every client needs it)
    DIR/server.key_secret    server secret key (stays on the server)
    DIR/client.key_secret    a client's key pair (give it to that client, with server.key)
    DIR/clients/NAME.key     public keys of the clients the server accepts

`pathcheck serve --new-keys DIR` writes a fresh folder (`new_keys`); more clients: copy their
`*.key` (made the same way) into `DIR/clients/`.
"""

from __future__ import annotations

import os
from pathlib import Path

from checker.errors import PathcheckError

SERVER, CLIENT, CLIENTS = "server", "client", "clients"


def new_keys(folder: str | Path) -> list[Path]:
    """Write a server and a client key pair into `folder` (created, must not hold keys yet),
    the client's public key into `folder/clients/`; secret files are 0600. The files written."""
    import zmq.auth

    folder = Path(folder)
    if (folder / f"{SERVER}.key_secret").exists():
        raise PathcheckError("already holds server keys; choose an empty folder", path=folder,
                             code="usage")
    (folder / CLIENTS).mkdir(parents=True, exist_ok=True)
    for name in (SERVER, CLIENT):
        _, secret = zmq.auth.create_certificates(str(folder), name)
        os.chmod(secret, 0o600)
    (folder / f"{CLIENT}.key").replace(folder / CLIENTS / f"{CLIENT}.key")
    return [folder / f"{SERVER}.key", folder / f"{SERVER}.key_secret",
            folder / f"{CLIENT}.key_secret", folder / CLIENTS / f"{CLIENT}.key"]


def server_keys(folder: str | Path) -> tuple[bytes, bytes, Path]:
    """`(public, secret, clients_folder)` of the server in a key folder."""
    folder = Path(folder)
    public, secret = _load(folder / f"{SERVER}.key_secret")
    clients = folder / CLIENTS
    if not clients.is_dir() or not any(clients.glob("*.key")):
        raise PathcheckError(f"expected the public keys of the allowed clients in {CLIENTS}/, "
                             "found none", path=folder, code="usage")
    return public, secret, clients


def client_keys(folder: str | Path) -> tuple[bytes, bytes, bytes]:
    """`(server_public, client_public, client_secret)` from a key folder."""
    folder = Path(folder)
    server_public, _ = _load(folder / f"{SERVER}.key")
    public, secret = _load(folder / f"{CLIENT}.key_secret")
    return server_public, public, secret


def _load(path: Path) -> tuple[bytes, bytes | None]:
    import zmq.auth

    try:
        public, secret = zmq.auth.load_certificate(str(path))
    except (OSError, ValueError) as err:
        raise PathcheckError(f"expected a CURVE key file (pathcheck serve --new-keys DIR), "
                             f"cannot read it: {err}", path=path, code="usage") from err
    if path.suffix == ".key_secret" and not secret:
        raise PathcheckError("expected a secret key, found a public key file only", path=path,
                             code="usage")
    return public, secret
