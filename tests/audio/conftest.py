"""Fixtures of the audio suite: a private PulseAudio server for capture through the real stack.

The server is set up here, by the tests themselves (no system service, no sound card). If
its programs are missing the fixture FAILS, naming the Debian packages: a silent skip would
let `make test` pass without ever testing capture.

PortAudio enumerates devices when sounddevice is imported. fingertip.audio imports it lazily,
and the fixture exports the server's address before anything in this process could import
it; if something did import it earlier, the fixture makes PortAudio enumerate again.
"""
from __future__ import annotations

import os
from collections.abc import Iterator

import pytest

from fingertip.audio import refresh_devices

from .pulse import PulseError, PulseServer


@pytest.fixture(scope="session")
def pulse_server() -> Iterator[PulseServer]:
    try:
        server = PulseServer()
    except PulseError as e:
        pytest.fail(str(e), pytrace=False)
    try:
        server.start()
    except PulseError as e:
        server.stop()
        pytest.fail(f"cannot start a private PulseAudio server: {e}", pytrace=False)
    client_env = server.client_env()
    saved = {k: os.environ.get(k) for k in client_env}
    os.environ.update(client_env)
    refresh_devices()
    try:
        yield server
    finally:
        for k, v in saved.items():
            if v is None:
                os.environ.pop(k, None)
            else:
                os.environ[k] = v
        pids = server.pids()
        server.stop()
        alive = server.alive()
        assert not alive, f"processes of the test PulseAudio server survived: {alive} of {pids}"
