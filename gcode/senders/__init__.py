"""Senders: stream G-code to a controller (GRBL serial, Modbus), and the Modbus register map.

Modules
-------
job
    Program -> compacted lines, each keeping its source line number; sync ($, EEPROM) lines.
grbl_messages, grbl_stream, grbl_events
    GRBL 1.1 replies; sans-IO streaming by character counting (128-byte buffer) or
    send-response, real-time bytes, status polling at <= 5 Hz (a report is never relied
    on), the end of a job, bounded waits; the events the stream reports.
grbl_sender, grbl_recovery
    The blocking driver over a link: handshake, ``$C`` dry run, run; safe stops (hold,
    reset) and where to resume.
link, serial_link
    The link interface; pyserial devices, ``socket://`` URLs and pseudo-terminals.
stream_options
    What a user chooses for a stream: ``StreamMode`` (pacing) and ``DEFAULT_BAUD``.
modbus_map
    The Modbus register map for streaming G-code blocks, as pure data (no pymodbus):
    register table, block-slot layout, commands, states, CRC-16 and word encoding. The
    simulator's Modbus server and the Modbus sender both import it.
modbus_stream, modbus_sender
    Sans-IO credit flow and idempotent writes over the map; the pymodbus TCP/RTU driver.
resume, journal
    Resume preamble (modal state, retract, move over, plunge; never mid-arc); the job journal.
preflight, progress, errors
    ``check_program`` gate before a byte is sent; progress records; ``SenderError``.
"""
