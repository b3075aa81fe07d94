"""Senders: stream G-code to a controller (GRBL serial, Modbus), and the Modbus register map.

Modules
-------
modbus_map
    The Modbus register map for streaming G-code blocks, as pure data (no pymodbus):
    register table, block-slot layout, commands, states, CRC-16 and word encoding. The
    simulator's Modbus server and the Modbus sender both import it.
"""
