"""The Modbus register map for streaming G-code blocks (map version 1), as data.

One table, :data:`REGISTERS`, is the single source for the simulator's server, the
sender, the documentation (``docs/modbus.md``, from :func:`register_table_markdown`) and
the tests. No pymodbus here: only addresses, types, scales and pure encode/decode.

Conventions
-----------
* Holding registers only (read FC3, write FC16; FC6 for single registers). Addresses are
  0-based PDU addresses (``mbpoll -0``; add 1 for 1-based "40001" tools).
* 32-bit values take two registers, high word first (big-endian words, ``mbpoll -B``).
* Text is ASCII, two characters per register, high byte first, zero-padded.
* Block slots: ``SLOT_COUNT`` slots of ``SLOT_STRIDE`` registers from ``SLOT_BASE``; the
  block with sequence number ``SEQ`` (1, 2, ...) goes to slot ``SEQ % SLOT_COUNT``, written
  whole in ONE FC16 request (:func:`encode_slot`), with a CRC-16/MODBUS of its text.

Handshake (see ``docs/modbus.md``): the host writes blocks while ``FREE_SLOTS > 0``
(credits), or one at a time waiting for ``ACCEPTED_SEQ == SEQ`` (send-response); a slot
whose SEQ is already accepted is ignored (idempotent retries); on a rejected block the
controller sets STATE=ERROR, ERROR_SEQ and ERROR_CODE and executes nothing after it; a
host that reconnects reads ``ACCEPTED_SEQ``/``DONE_SEQ`` and continues at
``ACCEPTED_SEQ + 1``. Commands are written as ``[CMD, CMD_SEQ]`` in one request; the
controller acts once per new ``CMD_SEQ`` and echoes it in ``CMD_ACK``.

Examples
--------
>>> regs = encode_slot(9, "G1X10F500")
>>> len(regs), slot_address(9), decode_slot(regs).text
(48, 148, 'G1X10F500')
>>> BY_NAME["ACCEPTED_SEQ"].address, decode_u32(*encode_u32(70000))
(26, 70000)
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from enum import Enum, IntEnum

__all__ = [
    "AXIS_NAMES",
    "BY_NAME",
    "MAP_VERSION",
    "POS_SCALE",
    "REGISTERS",
    "SLOT_BASE",
    "SLOT_CHARS",
    "SLOT_COUNT",
    "SLOT_CRC",
    "SLOT_LEN",
    "SLOT_SEQ",
    "SLOT_STRIDE",
    "SLOT_TEXT",
    "SLOT_TEXT_REGS",
    "STATUS_BLOCK",
    "TOTAL_REGISTERS",
    "Access",
    "BadWrite",
    "Command",
    "CommandResult",
    "DType",
    "MachineState",
    "Register",
    "Slot",
    "crc16_modbus",
    "decode_i32",
    "decode_slot",
    "decode_status",
    "decode_u32",
    "encode_i32",
    "encode_slot",
    "encode_u32",
    "register_table_markdown",
    "slot_address",
]

MAP_VERSION = 1
#: Block slots in the ring (credits the host may use at once).
SLOT_COUNT = 8
#: Largest block text, characters (GRBL's line buffer).
SLOT_CHARS = 80
#: First slot register and registers per slot.
SLOT_BASE = 100
SLOT_STRIDE = 48
#: Offsets inside a slot: SEQ (u32, 2 regs), LEN, FLAGS, TEXT (40 regs), CRC; 45-47 reserved.
SLOT_SEQ, SLOT_LEN, SLOT_FLAGS, SLOT_TEXT, SLOT_CRC = 0, 2, 3, 4, 44
SLOT_TEXT_REGS = SLOT_CHARS // 2
#: Position registers hold micrometres (mm x 1000) and millidegrees; FEED is mm/min x 1000.
POS_SCALE = 1000
AXIS_NAMES = ("X", "Y", "Z", "A", "B", "C")
TOTAL_REGISTERS = SLOT_BASE + SLOT_COUNT * SLOT_STRIDE


class Access(Enum):
    """Who writes a register."""

    R = "R"  #: the controller; host writes are refused (exception 2)
    W = "W"  #: the host; reads return the last value written


class DType(Enum):
    """Register encoding."""

    U16 = "u16"
    U32 = "u32"  #: two registers, high word first
    I32 = "i32"  #: two registers, high word first, two's complement

    @property
    def count(self) -> int:
        """Registers taken."""
        return 1 if self is DType.U16 else 2


class Command(IntEnum):
    """Values of CMD."""

    START = 1  #: cycle start (also resumes a completed hold)
    HOLD = 2  #: feed hold: decelerate and stop, queue kept
    RESUME = 3  #: resume after a hold
    ABORT = 4  #: feed hold, then reset once stopped: queue and unconsumed slots dropped
    CLEAR = 5  #: clear ERROR and unlock ALARM (a critical alarm is reset first)
    CHECK_ON = 6  #: check mode: parse only, no motion
    CHECK_OFF = 7  #: leave check mode (resets the parser)
    FLUSH = 8  #: drop accepted blocks not yet in the planner
    RESET = 9  #: soft reset now (ALARM 3 if the axes were moving)


class CommandResult(IntEnum):
    """Values of CMD_RESULT."""

    OK = 0
    UNKNOWN = 1  #: no such command
    REFUSED = 2  #: not possible in this state (e.g. CHECK_ON while running)


class MachineState(IntEnum):
    """Values of STATE."""

    IDLE = 0
    RUN = 1
    HOLD_PENDING = 2  #: decelerating to a hold
    HOLD = 3
    ALARM = 4
    CHECK = 5
    ERROR = 6  #: a block was rejected: see ERROR_SEQ / ERROR_CODE; CLEAR to go on


class BadWrite(IntEnum):
    """Values of LAST_BAD_REASON (slot writes ignored, counted in BAD_WRITES)."""

    NONE = 0
    CRC = 1  #: CRC of TEXT[0:LEN] does not match
    SLOT_INDEX = 2  #: written to a slot other than SEQ % SLOT_COUNT
    OUT_OF_WINDOW = 3  #: SEQ beyond the credits (> done-or-queued + SLOT_COUNT), or 0
    LENGTH = 4  #: LEN > SLOT_CHARS
    NOT_ACCEPTING = 5  #: STATE is ERROR or ALARM
    TEXT = 6  #: TEXT is not printable ASCII


@dataclass(frozen=True, slots=True)
class Register:
    """One named register (or pair).

    Attributes
    ----------
    name : str
        Upper-case identifier.
    address : int
        0-based PDU address of the (first) register.
    dtype : DType
        Encoding.
    access : Access
        R (controller writes) or W (host writes).
    unit : str
        Unit of the decoded value (after dividing by ``scale``).
    scale : int
        Raw value = decoded value x scale.
    doc : str
        Meaning.
    """

    name: str
    address: int
    dtype: DType
    access: Access
    unit: str
    scale: int
    doc: str

    @property
    def count(self) -> int:
        """Registers taken."""
        return self.dtype.count


def _r(name: str, address: int, dtype: str, access: str, doc: str, unit: str = "", scale: int = 1):
    return Register(name, address, DType(dtype), Access(access), unit, scale, doc)


REGISTERS: tuple[Register, ...] = (
    _r("PROTO_VERSION", 0, "u16", "R", "map version (1)"),
    _r("SLOT_COUNT", 1, "u16", "R", "block slots in the ring (8)"),
    _r("SLOT_CHARS", 2, "u16", "R", "largest block text, characters (80)"),
    _r("SLOT_STRIDE", 3, "u16", "R", "registers per slot (48)"),
    _r("SLOT_BASE", 4, "u16", "R", "address of slot 0 (100)"),
    _r("AXIS_MASK", 5, "u16", "R", "axes present: bit 0 X ... bit 5 C"),
    _r("PLANNER_BLOCKS", 6, "u16", "R", "planner queue size (15)"),
    _r("POS_SCALE", 7, "u16", "R", "position units per mm or deg (1000)"),
    _r("CMD", 10, "u16", "W", "command code (Command)"),
    _r("CMD_SEQ", 11, "u16", "W", "host increments per command; write with CMD in one request"),
    _r("HOST_HEARTBEAT", 12, "u16", "W", "host changes it >= 2 Hz; arms the watchdog"),
    _r("HEARTBEAT_TIMEOUT_MS", 13, "u16", "W", "watchdog: hold if unfed this long (0 off)", "ms"),
    _r("STATE", 20, "u16", "R", "MachineState"),
    _r("CMD_ACK", 21, "u16", "R", "last CMD_SEQ acted on"),
    _r("ALARM_CODE", 22, "u16", "R", "GRBL ALARM number, 0 when none"),
    _r("ERROR_CODE", 23, "u16", "R", "GRBL error number of the rejected block"),
    _r("ERROR_SEQ", 24, "u32", "R", "SEQ of the rejected block"),
    _r("ACCEPTED_SEQ", 26, "u32", "R", "highest SEQ accepted (contiguous, CRC good)"),
    _r("EXEC_SEQ", 28, "u32", "R", "SEQ of the block moving now (DONE_SEQ when none)"),
    _r("DONE_SEQ", 30, "u32", "R", "every block up to it has been executed"),
    _r("FREE_SLOTS", 32, "u16", "R", "slots the host may write now (credits)"),
    _r("CTRL_HEARTBEAT", 33, "u16", "R", "increments every controller cycle (wraps)"),
    _r("QUEUED_SEQ", 34, "u32", "R", "highest SEQ parsed into the planner"),
    _r("PLANNER_FREE", 36, "u16", "R", "free planner blocks"),
    _r("RESET_COUNT", 37, "u16", "R", "controller resets and restarts so far (wraps)"),
    _r("TIME_MS", 38, "u32", "R", "controller virtual time (wraps)", "ms"),
    _r("POS_X", 40, "i32", "R", "machine position X", "mm", POS_SCALE),
    _r("POS_Y", 42, "i32", "R", "machine position Y", "mm", POS_SCALE),
    _r("POS_Z", 44, "i32", "R", "machine position Z", "mm", POS_SCALE),
    _r("POS_A", 46, "i32", "R", "machine position A", "deg", POS_SCALE),
    _r("POS_B", 48, "i32", "R", "machine position B", "deg", POS_SCALE),
    _r("POS_C", 50, "i32", "R", "machine position C", "deg", POS_SCALE),
    _r("FEED", 52, "i32", "R", "current feed", "mm/min", POS_SCALE),
    _r("CMD_RESULT", 54, "u16", "R", "CommandResult of the last command"),
    _r("BAD_WRITES", 55, "u16", "R", "slot writes ignored (wraps)"),
    _r("LAST_BAD_REASON", 56, "u16", "R", "BadWrite of the last ignored slot write"),
    _r("DUPLICATE_WRITES", 57, "u16", "R", "slot writes of an already accepted SEQ (wraps)"),
)  # fmt: skip
BY_NAME: dict[str, Register] = {r.name: r for r in REGISTERS}
#: One FC3 read of this (address, count) returns every status register.
STATUS_BLOCK = (20, 38)


@dataclass(frozen=True, slots=True)
class Slot:
    """A decoded block slot.

    Attributes
    ----------
    seq : int
        Block sequence number (>= 1).
    length : int
        Text length, characters.
    flags : int
        Reserved (0).
    text_bytes : bytes
        ``TEXT[0:length]``.
    crc : int
        CRC as written.
    """

    seq: int
    length: int
    flags: int
    text_bytes: bytes
    crc: int

    @property
    def text(self) -> str:
        """The text as ASCII (undecodable bytes replaced)."""
        return self.text_bytes.decode("ascii", errors="replace")

    @property
    def crc_ok(self) -> bool:
        """The CRC matches the text."""
        return crc16_modbus(self.text_bytes) == self.crc


def crc16_modbus(data: bytes) -> int:
    """CRC-16/MODBUS (poly 0xA001 reflected, init 0xFFFF) of ``data``.

    >>> hex(crc16_modbus(b"123456789"))
    '0x4b37'
    """
    crc = 0xFFFF
    for b in data:
        crc ^= b
        for _ in range(8):
            crc = (crc >> 1) ^ 0xA001 if crc & 1 else crc >> 1
    return crc


def encode_u32(value: int) -> list[int]:
    """Two registers, high word first (0 <= value < 2**32; larger values wrap)."""
    v = int(value) & 0xFFFFFFFF
    return [v >> 16, v & 0xFFFF]


def decode_u32(hi: int, lo: int) -> int:
    """Inverse of :func:`encode_u32`."""
    return ((hi & 0xFFFF) << 16) | (lo & 0xFFFF)


def encode_i32(value: int) -> list[int]:
    """Two registers, high word first, two's complement (clamped to the int32 range)."""
    v = max(-(2**31), min(2**31 - 1, int(value)))
    return encode_u32(v & 0xFFFFFFFF)


def decode_i32(hi: int, lo: int) -> int:
    """Inverse of :func:`encode_i32`."""
    v = decode_u32(hi, lo)
    return v - (1 << 32) if v & 0x80000000 else v


def slot_address(seq: int) -> int:
    """First register of the slot that block ``seq`` goes to."""
    return SLOT_BASE + (seq % SLOT_COUNT) * SLOT_STRIDE


def encode_slot(seq: int, text: str, flags: int = 0) -> list[int]:
    """The 48 registers of one block slot, ready for one FC16 write.

    Raises
    ------
    ValueError
        For seq < 1, text longer than :data:`SLOT_CHARS` or not printable ASCII.
    """
    if seq < 1 or seq >= 2**32:
        raise ValueError(f"block SEQ must be 1 .. 2**32-1, got {seq!r}")
    try:
        data = text.encode("ascii")
    except UnicodeEncodeError:
        raise ValueError(f"block text must be ASCII, got {text!r}") from None
    if len(data) > SLOT_CHARS:
        raise ValueError(f"block text has {len(data)} characters, the slot holds {SLOT_CHARS}")
    if any(b < 0x20 or b > 0x7E for b in data):
        raise ValueError(f"block text must be printable ASCII (no line ends), got {text!r}")
    padded = data + b"\0" * (SLOT_CHARS - len(data))
    regs = [*encode_u32(seq), len(data), flags]
    regs += [(padded[i] << 8) | padded[i + 1] for i in range(0, SLOT_CHARS, 2)]
    regs += [crc16_modbus(data), 0, 0, 0]
    return regs


def decode_slot(regs: Sequence[int]) -> Slot:
    """Read a slot from its registers (at least up to the CRC).

    Raises
    ------
    ValueError
        If fewer than ``SLOT_CRC + 1`` registers are given.
    """
    if len(regs) < SLOT_CRC + 1:
        raise ValueError(f"a slot needs {SLOT_CRC + 1} registers up to its CRC, got {len(regs)}")
    seq = decode_u32(regs[SLOT_SEQ], regs[SLOT_SEQ + 1])
    length = regs[SLOT_LEN]
    raw = bytearray()
    for r in regs[SLOT_TEXT : SLOT_TEXT + SLOT_TEXT_REGS]:
        raw += bytes(((r >> 8) & 0xFF, r & 0xFF))
    return Slot(
        seq, length, regs[SLOT_FLAGS], bytes(raw[: min(length, SLOT_CHARS)]), regs[SLOT_CRC]
    )


def decode_status(regs: Sequence[int], base: int = STATUS_BLOCK[0]) -> dict[str, float]:
    """Decode every status register found in ``regs`` read from address ``base``.

    Returns
    -------
    dict of str to float
        Name -> value in the register's unit (positions in mm or deg, FEED in mm/min,
        others as integers).
    """
    out: dict[str, float] = {}
    for r in REGISTERS:
        i = r.address - base
        if i < 0 or i + r.count > len(regs):
            continue
        if r.dtype is DType.U16:
            raw = regs[i]
        elif r.dtype is DType.U32:
            raw = decode_u32(regs[i], regs[i + 1])
        else:
            raw = decode_i32(regs[i], regs[i + 1])
        out[r.name] = raw / r.scale if r.scale != 1 else raw
    return out


def register_table_markdown() -> str:
    """The register table as Markdown (pasted into ``docs/modbus.md``)."""
    lines = ["| addr | name | type | access | unit | meaning |", "|---|---|---|---|---|---|"]
    for r in REGISTERS:
        addr = str(r.address) if r.count == 1 else f"{r.address}-{r.address + 1}"
        unit = r.unit + (f" (x{r.scale})" if r.scale != 1 else "")
        lines.append(
            f"| {addr} | {r.name} | {r.dtype.value} | {r.access.value} | {unit} | {r.doc} |"
        )
    return "\n".join(lines)
