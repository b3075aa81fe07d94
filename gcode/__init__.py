"""G-code: the canonical program model, dialect posts, emitter, strict parser, senders.

Will own: frozen block types and ``Program``; the one number formatter; dialects as data
(GRBL, LinuxCNC, Fanuc-style); a streaming emitter behind a writer interface; an atomic,
line-numbered parser and the expanding interpreter shared with the simulator;
``check_program``; and ``gcode.senders`` (serial GRBL and Modbus streaming).
"""
