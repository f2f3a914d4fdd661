"""A ``std_srvs/srv/Trigger`` server's logic, whatever carries its requests (DDS request
and reply topics, a Zenoh queryable): one request at a time on a worker thread, bad or
concurrent requests refused with ``success: false`` and counted, nothing raised into the
transport's thread."""
from __future__ import annotations

import logging
import struct
import threading
from collections.abc import Callable
from dataclasses import dataclass, field

log = logging.getLogger(__name__)

Answer = Callable[[bool, str], None]
"""Sends the reply (success, message) to the request's client."""


@dataclass
class ServiceStats:
    requests: int = 0
    answered: int = 0
    refused: int = 0
    """Malformed, oversized or failing requests (answered with success = false when they
    carried a readable request id, dropped otherwise)."""
    reasons: dict[str, int] = field(default_factory=dict)
    dropped_by: Callable[[], int] | None = field(default=None, repr=False, compare=False)
    """The transport's count of requests lost before they reached the service (DDS: the
    request reader's lost and rejected samples)."""

    @property
    def dropped(self) -> int:
        """Requests sent to the service that never reached it (counted by the transport)."""
        return self.dropped_by() if self.dropped_by is not None else 0

    def text(self) -> str:
        """``N requests, A answered, R refused {reasons}, D dropped``."""
        reasons = f" {self.reasons}" if self.reasons else ""
        return (f"{self.requests} requests, {self.answered} answered, {self.refused} refused"
                f"{reasons}, {self.dropped} dropped")


def trigger_response_cdr(success: bool, message: str) -> bytes:
    """The members of a ``std_srvs/srv/Trigger`` response in little-endian CDR, after the
    encapsulation header and whatever request id the transport puts ahead (both keep the
    members 4-byte aligned, so the bytes are the same)."""
    text = message.encode("utf-8") + b"\0"
    return bytes([1 if success else 0]) + b"\0\0\0" + struct.pack("<I", len(text)) + text


class TriggerServer:
    """``handler()`` returns ``(success, message)``; it runs on a worker thread (a tare
    takes a while), never two at once."""

    def __init__(self, service: str, handler: Callable[[], tuple[bool, str]],
                 stats: ServiceStats | None = None) -> None:
        self.service = service
        self.handler = handler
        self.stats = stats or ServiceStats()
        self._busy = threading.Lock()

    def refuse(self, reason: str, text: str, answer: Answer | None) -> None:
        """Count a refused request; answer it when it can be answered."""
        st = self.stats
        st.refused += 1
        st.reasons[reason] = st.reasons.get(reason, 0) + 1
        # Busy is an answer, not a fault (a burst of requests gets one each): debug only.
        log.log(logging.DEBUG if reason == "busy" else logging.WARNING,
                "%s: refused a request (%s)", self.service, text)
        if answer is not None:
            answer(False, text)

    def request(self, answer: Answer) -> None:
        """A well-formed request: run the handler, or refuse it while one runs."""
        if not self._busy.acquire(blocking=False):
            self.refuse("busy", "busy: the previous request is still running", answer)
            return
        threading.Thread(target=self._run, args=(answer,), daemon=True,
                         name=f"service{self.service}").start()

    def _run(self, answer: Answer) -> None:
        try:
            ok, text = self.handler()
        except Exception as e:  # the service reports the failure; the node goes on
            ok, text = False, f"failed: {e}"
        finally:
            self._busy.release()
        if not ok:
            self.stats.reasons["failed"] = self.stats.reasons.get("failed", 0) + 1
        self.stats.answered += 1
        try:
            answer(ok, text)
        except Exception as e:  # the client is gone: nothing to tell it
            log.warning("%s: could not answer (%s)", self.service, e)
