"""Subcommands of ``toolpath``, one module each.

A module here defines ``register(commands)``, which adds its sub-parser to the
``argparse`` sub-parsers object and sets ``handler=<function(args) -> int>`` as a default.
The CLI discovers the modules, so adding a command touches no shared file.
"""
