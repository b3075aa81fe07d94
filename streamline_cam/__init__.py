"""The service layer: one pipeline from points to a running machine, and the CLI.

Top of the import graph: it may import every package of ours; none imports it.
"""
