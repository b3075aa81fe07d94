"""A software CNC controller for tests and the demo.

Will own: a controller core on an injectable virtual clock (planner queue, trapezoidal
motion, states, soft limits, journal); a sans-IO GRBL 1.1 protocol front end; pseudo-terminal
and TCP transports; a pymodbus Modbus TCP/RTU server over the shared register map; and fault
injection. Nothing else imports this package.
"""
