"""Subcommands of ``toolpath``, one module each.

A module here defines ``register(commands)``, which adds its sub-parser to the
``argparse`` sub-parsers object and sets ``handler=<function(args) -> int>`` as a default.
The CLI discovers the modules, so adding a command touches no shared file.

``register`` declares the parser only: a module imports at its top what the parser needs
(the standard library and the numpy-free modules of names and defaults, such as
``machines.catalog``, ``gcode.dialects``, ``toolpath.planning.defaults``) and imports its
work (numpy, the planner, the senders, the service) inside the handler, so ``toolpath
--help`` and ``toolpath CMD --help`` load none of it (``tests/test_startup.py``).
"""
