"""What a user chooses for a stream: pacing mode and baud rate (standard library only).

``toolpath send --help`` lists them without loading the senders; :mod:`.grbl_stream` and
:mod:`.serial_link` use the same definitions.
"""

from __future__ import annotations

from enum import StrEnum

__all__ = ["DEFAULT_BAUD", "StreamMode"]

#: GRBL 1.1's default baud rate (8N1).
DEFAULT_BAUD = 115200


class StreamMode(StrEnum):
    """How lines are paced."""

    CHAR_COUNT = "char-count"
    SEND_RESPONSE = "send-response"
